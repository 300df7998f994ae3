"""The whole stack on simulated CANopen drives, for system tests: simulator and CANopen driver as processes
(on a loopback bus of the test's own), the other nodes and the operator's probe in the test's process.
:func:`fault_episode` injects one fault and measures the robot's answer, from the drives' SYNC trace and from
driver_node's /diagnostics."""

from __future__ import annotations

import contextlib
import os
import threading
import time
import weakref
from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from rrps_hardware.interface import FaultKind
from rrps_interfaces.climb import CLIMB_RESUME, CLIMB_STATUS, ClimbState, ClimbStatus
from rrps_interfaces.kinematics import POSE
from rrps_interfaces.teleop import TELEOP_ENABLE, TELEOP_STATUS, TeleopStatus
from rrps_runtime.supervision import OPERATOR_NICE, OPERATOR_RT_PRIORITY, raise_priority, stop_children
from rrps_testing.canopen_rig import DriveSim, driver_process
from rrps_testing.driver_probe import DriverProbe
from rrps_testing.ros_harness import Spinner, wait_for

__all__ = ['STEP_DEADLINE', 'DriverRig', 'Stack', 'driver_processes', 'activated_driver', 'canopen_stack',
           'FaultEpisode', 'fault_episode', 'hold_time', 'teleop_status', 'engage', 'call', 'climb_state',
           'finish_step']

NAMESPACE = '/rrps_canopen'
#: s: a hang guard (it times nothing) for a climbing step's preview (climb/status IDLE until it
#: starts; over a minute beside ``./rrps test --load``) and for each run of it until it pauses or ends.
STEP_DEADLINE = 180.0


@dataclass
class DriverRig:
    """The simulator, the driver process (activated) and the operator's probe."""

    sim: DriveSim
    driver: object
    probe: DriverProbe


@dataclass
class Stack(DriverRig):
    """What a test drives: the simulator, the driver process, the in-process nodes, the probe."""

    nodes: dict
    poses: list
    teleop_status: list
    climb_status: list
    deadman: threading.Event


@contextlib.contextmanager
def driver_processes(domain_id: int, *, robot: str = 'pole_climber', hardware: str = 'canopen',
                     driver_params: tuple[str, ...] = ()):
    """The drive simulator (``hardware='canopen'``) and driver_node (``auto_activate``) as processes
    of their own; yields (sim or None, driver). Stops both; the driver must end cleanly."""
    sim = DriveSim(robot) if hardware == 'canopen' else None
    processes = []
    try:
        processes.append(driver_process(sim.port if sim is not None else 0, 'auto_activate:=true', *driver_params,
                                        robot=robot, namespace=NAMESPACE, domain_id=domain_id, hardware=hardware))
        yield sim, processes[0]
    finally:
        codes = stop_children(processes)
        if sim is not None:
            sim.stop()
    failed = [p for p, code in zip(processes, codes) if code != 0]
    assert not failed, failed[0].stderr.read()[-3000:]


#: Bring-ups tried: on a loaded machine the drive simulator (one process standing in for seven
#: devices) can stall past the drives' heartbeat consumer time before the test starts.
BRING_UP_ATTEMPTS = 3


def wait_active(probe: DriverProbe, driver) -> None:
    """Until driver_node reports itself active (auto_activate). Heartbeats lost at bring-up (every
    latched fault a lost heartbeat) are reset and the driver activated again, as the operator
    does, at most :data:`BRING_UP_ATTEMPTS` times; any other fault fails the test."""
    for _ in range(BRING_UP_ATTEMPTS):
        assert wait_for(lambda: probe.latest() and (probe.latest()[3].active or probe.latest()[3].faults)), (
            driver.poll(), probe.latest())
        status = probe.latest()[3]
        if status.active:
            return
        assert all(f.endswith(':' + FaultKind.LOST_HEARTBEAT.value) for f in status.faults), (driver.poll(), status)
        print(f'\n  bring-up: {", ".join(status.faults)}; reset and activate', flush=True)
        assert wait_for(lambda: probe.reset_faults()[0], period=0.2), (driver.poll(), probe.latest())
        probe.activate()
    assert wait_for(lambda: probe.latest()[3].active), (driver.poll(), probe.latest())


@contextlib.contextmanager
def activated_driver(context, domain_id: int, *, robot: str = 'pole_climber', driver_params: tuple[str, ...] = ()):
    """The simulated drives and the CANopen driver, activated, with the operator's probe: a
    :class:`DriverRig` (faults of the bus and of the grippers need no kinematics)."""
    with driver_processes(domain_id, robot=robot, driver_params=driver_params) as (sim, driver):
        probe = DriverProbe(context=context, namespace=NAMESPACE)
        with Spinner(context, [probe]):
            wait_active(probe, driver)
            yield DriverRig(sim, driver, probe)


@contextlib.contextmanager
def canopen_stack(context, domain_id: int, *, robot: str = 'pole_climber', hardware: str = 'canopen',
                  driver_params: tuple[str, ...] = ()):
    """The stack (see the module docstring); ``hardware='simulated'`` runs the simulated driver
    process instead, for comparisons. The deadman is held (20 Hz) while ``stack.deadman`` is set."""
    from rrps_bringup.demo import build_stack
    with driver_processes(domain_id, robot=robot, hardware=hardware, driver_params=driver_params) as (sim, driver):
        nodes = build_stack(context, robot=robot, host='127.0.0.1', port=0, token='', viewer=False, climb=True,
                            driver=False, kinematics=True, namespace=NAMESPACE)
        probe = DriverProbe(context=context, namespace=NAMESPACE)
        poses = probe.collect(PoseStamped, POSE, stamped=True)
        teleop_status = probe.collect(DiagnosticStatus, TELEOP_STATUS, stamped=True)
        climb_status = probe.collect(DiagnosticStatus, CLIMB_STATUS, stamped=True)
        enable = probe.publisher(Bool, TELEOP_ENABLE, command=True)
        deadman, stop = threading.Event(), threading.Event()

        def hold() -> None:
            while not stop.wait(0.05):
                if deadman.is_set():
                    enable.publish(Bool(data=True))
        thread = threading.Thread(target=hold, daemon=True)
        with contextlib.ExitStack() as running:
            with operator_priority():
                running.enter_context(Spinner(context, [*nodes.values(), probe]))
                thread.start()
            try:
                assert wait_for(lambda: poses), (driver.poll(), probe.latest())
                wait_active(probe, driver)
                yield Stack(sim, driver, probe, nodes, poses, teleop_status, climb_status, deadman)
            finally:
                stop.set()
                thread.join()


@contextlib.contextmanager
def operator_priority():
    """Threads started inside run as the demo runs the operator station (SCHED_RR at
    OPERATOR_RT_PRIORITY where permitted, below the driver and the simulator), not at the test
    process' priority; the calling thread then returns to its own."""
    nice = os.getpriority(os.PRIO_PROCESS, 0)
    raise_priority(OPERATOR_NICE, realtime=OPERATOR_RT_PRIORITY)
    try:
        yield
    finally:
        raise_priority(nice)


def hold_time(trace: list, t_inject: float) -> tuple[float, float]:
    """From the simulator's trace (time, targets, positions, ...) of every SYNC: when the drives'
    targets stopped changing for good after ``t_inject`` [s after it], and how far any leg moved
    from ``t_inject`` to the end of the trace [m]."""
    times = np.array([row[0] for row in trace])
    targets = np.array([row[1] for row in trace])
    positions = np.array([row[2] for row in trace])
    changed = np.flatnonzero(np.any(np.abs(np.diff(targets, axis=0)) > 1e-9, axis=1))
    after = changed[times[changed + 1] >= t_inject]
    t_hold = times[after[-1] + 1] if after.size else t_inject
    start = np.searchsorted(times, t_inject)
    moved = np.abs(positions[start:] - positions[min(start, len(positions) - 1)]).max() if start < len(times) else 0.0
    return float(t_hold - t_inject), float(moved)


@dataclass
class FaultEpisode:
    """One injected fault: the report's delay, the time to hold, the motion after the fault [m],
    the gripper outputs switched after it, the report, whether reset and activation worked."""

    kind: str
    drive: str
    report_delay: float
    time_to_hold: float
    motion: float
    gripper_switches: int
    report: str
    recovered: bool
    reset_message: str


#: What each simulator fault is reported as: (DriverStatus fault kind, all drives?).
REPORTED = {'current': ('emergency', False), 'fault_bit': ('drive_fault', False),
            'blocked': ('following_error', False), 'silent': ('lost_heartbeat', False),
            'reboot': ('rebooted', False), 'bus': ('bus_lost', True), 'bus_off': ('bus_lost', True)}


def fault_episode(stack: DriverRig, kind: str, drive: str, *, window: float = 0.5,
                  deadline: float = 60.0) -> FaultEpisode:
    """Inject ``kind`` (a key of :data:`REPORTED`) in ``drive`` now, wait for driver_node's
    report, watch the drives ``window`` s more, bring the link back (silent drive, bus), reset
    the faults and activate again."""
    sim, probe = stack.sim, stack.probe
    outputs0 = sim.status().get('io', {}).get('outputs')
    sim.ask(cmd='trace', on=True)
    if kind in ('bus', 'bus_off'):
        t_inject = sim.ask(cmd='bus', up=False)['time'] if kind == 'bus' else sim.ask(cmd='bus_off')['time']
    else:
        t_inject = sim.fault(drive, kind)
    expected, everyone = REPORTED[kind]
    wanted = {f'leg_{i}:{expected}' for i in range(1, 7)} if everyone else {f'{drive}:{expected}'}

    def reported():
        latest = probe.latest()
        return latest if latest and latest[1] == 2 and wanted <= set(latest[3].faults) else None
    ok = wait_for(reported, timeout=deadline)
    first = next((t for t, level, _, status in list(probe.statuses)
                  if t >= t_inject and level == 2 and wanted <= set(status.faults)), None)
    report = reported() or probe.latest()
    time.sleep(window)
    trace = sim.ask(cmd='trace', on=False)['trace']
    outputs1 = sim.status().get('io', {}).get('outputs')
    if kind == 'silent':
        sim.ask(cmd='restore', drive=drive)
    elif kind == 'bus':
        sim.ask(cmd='bus', up=True)
    messages: list[str] = []

    def reset() -> bool:
        success, message = probe.reset_faults()
        messages.append(message)
        return success
    recovered = ok and wait_for(reset, timeout=deadline, period=0.2)
    recovered = recovered and probe.activate() and wait_for(
        lambda: probe.latest()[3].active and not probe.latest()[3].faults, timeout=deadline)
    if trace:
        t_hold, moved = hold_time(trace, t_inject)
    else:  # a cut bus: no SYNC and no target reached the drives after it, they kept their last one
        t_hold, moved = (0.0, 0.0) if kind == 'bus' else (float('nan'), float('nan'))
    switches = 0 if outputs0 == outputs1 else bin((outputs0 or 0) ^ (outputs1 or 0)).count('1')
    return FaultEpisode(kind, drive, (first - t_inject) if first is not None else float('nan'), t_hold, moved,
                        switches, report[2] if report else 'no report', bool(recovered),
                        messages[-1] if messages else '')


# --- the operator ---

def teleop_status(stack: Stack) -> TeleopStatus | None:
    """The latest teleop/status."""
    return TeleopStatus.from_key_values(stack.teleop_status[-1][1].values) if stack.teleop_status else None


def engage(stack: Stack) -> None:
    """Release and press the deadman, as an operator does after a fault; wait until the slave moves."""
    stack.deadman.clear()
    time.sleep(0.3)
    stack.deadman.set()
    assert wait_for(lambda: teleop_status(stack) is not None and teleop_status(stack).engaged), teleop_status(stack)
    n = len(stack.poses)
    assert wait_for(lambda: len(stack.poses) > n + 20 and np.ptp(
        [m.pose.position.z for _, m in stack.poses[-20:]]) > 1e-6), 'the slave does not move'


#: The Trigger clients of each stack's probe, by service name. Keyed by the probe itself, not by its id():
#: a later test's probe may be allocated where a destroyed one was, and got that one's destroyed clients.
_CLIENTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def call(stack: Stack, name: str) -> tuple[bool, str]:
    """Call the Trigger service ``name``; (success, message)."""
    clients = _CLIENTS.setdefault(stack.probe, {})
    if name not in clients:
        clients[name] = stack.probe.create_client(Trigger, name)
    client = clients[name]
    assert client.wait_for_service(timeout_sec=60)
    future = client.call_async(Trigger.Request())
    assert wait_for(future.done)
    return future.result().success, future.result().message


def climb_state(stack: Stack) -> ClimbStatus | None:
    """The latest climb/status."""
    return ClimbStatus.from_key_values(stack.climb_status[-1][1].values) if stack.climb_status else None


def finish_step(stack: Stack, resumes: int = 30) -> None:
    """Wait for the requested step to start (it stays IDLE while it is previewed), then resume it
    (paused by a fault, or by a late state on a busy machine) until it ends idle. After each
    resume, the next climb/status published after it tells the state (the step may pause again
    before a poll would see it run)."""
    def started() -> bool:
        s = climb_state(stack)
        return s is not None and (s.state is not ClimbState.IDLE or (s.refusal is not None and not s.previewing))
    assert wait_for(started, timeout=STEP_DEADLINE), climb_state(stack)
    assert climb_state(stack).refusal is None, climb_state(stack)
    for _ in range(resumes):
        assert wait_for(lambda: climb_state(stack).state in (ClimbState.PAUSED, ClimbState.IDLE, ClimbState.FAILED),
                        timeout=STEP_DEADLINE), climb_state(stack)
        if climb_state(stack).state is not ClimbState.PAUSED:
            break
        answers = []
        assert wait_for(lambda: answers.append(call(stack, CLIMB_RESUME)) or answers[-1][0], period=0.5), (
            answers[-1], climb_state(stack), stack.probe.latest())
        resumed = time.monotonic()
        assert wait_for(lambda: stack.climb_status[-1][0] > resumed), climb_state(stack)
    assert climb_state(stack).state is ClimbState.IDLE, climb_state(stack)
