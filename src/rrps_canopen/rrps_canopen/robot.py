"""The CANopen hardware of a robot behind the driver's interface: ``hardware: canopen``.

:class:`CanopenRobot` is a :class:`~rrps_hardware.interface.SystemInterface` over the robot YAML's
``bus`` section: six CiA 402 leg drives in cyclic synchronous position mode
(:class:`~rrps_canopen.drive_set.DriveSet`) and the grippers' I/O (:class:`~rrps_canopen.grippers.GripperIo`).
``on_configure`` checks and configures every device or fails leaving none half-configured;
``on_activate`` homes (:mod:`rrps_canopen.homing`), checks the legs and enables the drives where
they are; a fault holds every drive and refuses commands and grippers until ``reset_faults`` and a
new activation (docs/connecting-a-robot.md). Commands and state are in metres
(:mod:`rrps_canopen.units`). ``write`` hands each new command to the legs' jerk-limited setpoints
(:class:`~rrps_hardware.setpoints.JerkLimitedSetpoints`); the bus' SYNC cycle, a real-time thread of
its own, steps them just before each SYNC and sends them as the drives' targets, so a command is
on the bus with the next SYNC however the driver's executor is held up. Pure Python, no ROS import.
"""

from __future__ import annotations

import threading
from time import monotonic as time_now

import can
import numpy as np

from rrps_canopen.cia402 import HomingStatus, Mode, State, Statusword
from rrps_canopen.drive import ConfigureError
from rrps_canopen.drive_set import DriveSet
from rrps_canopen.grippers import GripperIo
from rrps_canopen.homing import check_positions, home, homing_timeout, refuse, set_mode
from rrps_canopen.network import resolve_eds
from rrps_description.names import LEG_NAMES, RINGS
from rrps_hardware.commands import ring_joints
from rrps_hardware.interface import (
    OK,
    SUCCESS,
    ActuatorStatus,
    BusState,
    CallbackReturn,
    Command,
    HardwareConfig,
    Result,
    ReturnType,
    SystemInterface,
    SystemState,
    Transition,
)
from rrps_hardware.setpoints import MAX_STEP_PERIODS, JerkLimitedSetpoints
from rrps_runtime.freshness import RecentDurations
from rrps_runtime.scheduling import Granted, claim

__all__ = ['CanopenRobot']


def _error(message: str) -> Result:
    return Result(ReturnType.ERROR, message)


def _failure(message: str) -> Transition:
    return Transition(CallbackReturn.FAILURE, message)


#: The name of python-can's receive thread (``can.Notifier``'s, one per bus) begins so.
RECEIVE_THREAD = 'Notifier for bus'


def claim_bus_threads(config: HardwareConfig) -> tuple[Granted, Granted] | None:
    """The bus' threads above the driver's command path (its ``rt_priority``, ``cpu_affinity``):
    the SYNC cycle two priorities higher, python-can's receive thread one higher, so the cycle
    never waits for the driver's executor (rrps_runtime.scheduling); what they got, or None
    without a scheduling request."""
    request = config.scheduling
    if request is None:
        return None
    threads = [(t.name, t.native_id) for t in threading.enumerate() if t.native_id is not None]
    return (claim(request.shifted(2), [tid for name, tid in threads if name == 'canopen-sync']),
            claim(request.shifted(1), [tid for name, tid in threads if name.startswith(RECEIVE_THREAD)]))


class CanopenRobot(SystemInterface):
    """A robot's legs and grippers on a CANopen bus (see the module docstring)."""

    OWN_CYCLE = True   # the SYNC cycle steps the setpoints

    def __init__(self):
        self.drives: DriveSet | None = None
        self.grippers: GripperIo | None = None
        self.geometry = None
        self.active = False
        self._last: SystemState | None = None
        #: what the SYNC cycle and the receive thread got (claim_bus_threads)
        self.bus_scheduling: tuple[Granted, Granted] | None = None
        self._limits = None
        self.setpoints: JerkLimitedSetpoints | None = None
        self._commanded: Command | None = None
        self._stepped: float | None = None   # when the SYNC cycle last came [s]
        self._received: float | None = None  # when the newest command not yet sent came [s]
        #: from a command's receipt (``write``) to the SYNC cycle that sends its first setpoint
        self.target_latency = RecentDurations()

    # --- lifecycle ---

    def on_configure(self, config: HardwareConfig) -> Transition:
        if self.drives is not None:
            return SUCCESS
        g = config.geometry
        if g.bus is None:
            return _failure(f'robot {g.name!r} has no bus section: the canopen hardware needs one '
                            '(docs/connecting-a-robot.md)')
        if ring_joints(g):
            return _failure(f'the canopen hardware drives the six legs; {", ".join(ring_joints(g))} have no drive')
        try:
            self._limits = g.motion_limits.legs
        except ValueError as exc:
            return _failure(str(exc))
        io = g.bus.grippers
        if io is None and any(kind != 'none' for kind in g.grippers.values()):
            return _failure(f'robot {g.name!r} has grippers but its bus section has no grippers entry')
        on_drives = io is not None and io.io == 'drive'
        digital_io = frozenset(ch.drive for ch in io.rings.values()) if on_drives else frozenset()
        try:
            self.drives = DriveSet(g.bus, Mode.CYCLIC_SYNCHRONOUS_POSITION, digital_io=digital_io,
                                   extra=self._extra)
        except (ConfigureError, FileNotFoundError, can.CanError, OSError, ValueError) as exc:
            self.drives = None
            return _failure(f'canopen bus {g.bus.interface} {g.bus.channel}: {exc}')
        try:
            if io is not None:
                by_name = {d.name: d for d in self.drives.drives}
                eds = resolve_eds(io.eds, g.bus.base_dir) if io.io == 'cia401' else ''
                self.grippers = GripperIo(io, self.drives.network, by_name, g.grippers, eds,
                                          sdo_timeout=g.bus.sdo_timeout, heartbeat_timeout=g.bus.heartbeat_timeout,
                                          latch=self.drives.latch, sdo_retries=g.bus.sdo_retries)
                self.grippers.check()
            self.drives.configure()
            self.bus_scheduling = claim_bus_threads(config)
            if self.grippers is not None:
                self.grippers.configure(g.bus.heartbeat_period)
        except (ConfigureError, FileNotFoundError) as exc:
            self.drives.close(stop_drives=True)
            self.drives = self.grippers = None
            return _failure(str(exc))
        self._last = None
        self.geometry = g
        return Transition(CallbackReturn.SUCCESS, self.drives.notes)

    def _extra(self, now: float) -> None:
        """Each SYNC cycle, under the drive set's lock: the grippers' outputs, the legs' setpoints."""
        if self.grippers is not None:
            self.grippers.cycle(now, alive=self.drives.alive)
        self._step_setpoints(now)

    def _step_setpoints(self, now: float) -> None:
        """The drives' targets one SYNC along the setpoints, while active, unfaulted and commanded
        (a hold or a fault leaves them where the drive set put them)."""
        d, last, self._stepped = self.drives, self._stepped, now
        if not self.active or d.faults or self._commanded is None or last is None:
            return
        for drive, x in zip(d.drives, self.setpoints.step(now, min(now - last, MAX_STEP_PERIODS * d.period))):
            drive.target = drive.scale.counts(float(x))
        if self._received is not None:
            sent = time_now()
            self.target_latency.add(sent, sent - self._received)
            self._received = None

    def on_activate(self) -> Transition:
        d = self.drives
        if d is None:
            return _failure('not configured')
        with d.lock:
            if d.bus_lost:
                return _failure('the bus is lost')
            if d.faults:
                return _failure(f'activation failed: {self._faults_text()}: reset the faults first')
        unhomed = [drive for drive in d.drives if not drive.homed]
        if unhomed:
            reason, statuses = home(d, unhomed, homing_timeout(unhomed))
            if reason:
                seen = statuses or {}
                problems = {} if statuses is None else {
                    drive.name: f'homing {seen[drive.name].value}' if drive.name in seen else 'homing not done'
                    for drive in unhomed if seen.get(drive.name) is not HomingStatus.COMPLETED}
                refused = refuse(d, problems, fault=statuses is not None) or 'drives disabled'
                return _failure(f'activation failed: {reason}: {refused}')
        with d.lock:
            lengths = np.array([drive.scale.position(d.data[drive.name].position) for drive in d.drives])
        problems = check_positions(self.geometry, d.bus.drives, lengths, {drive.name for drive in unhomed})
        if problems:
            return _failure(f'activation refused, drives disabled: {refuse(d, problems, fault=bool(unhomed))}')
        for drive in unhomed:
            drive.homed = True
        reason = set_mode(d, d.drives, Mode.CYCLIC_SYNCHRONOUS_POSITION) or d.enable()
        if reason:
            return _failure(f'activation failed: {reason}: {refuse(d, {}, fault=False) or "drives disabled"}')
        d.hold()
        self._follow_targets()
        self.active = True
        return SUCCESS

    def _follow_targets(self) -> None:
        """The setpoints at rest where the drives hold (after a hold: no jump to an older command)."""
        d = self.drives
        with d.lock:
            targets = [drive.scale.position(drive.target) for drive in d.drives]
            self.setpoints = JerkLimitedSetpoints(self._limits, targets)
            self._commanded = self._received = None

    def on_deactivate(self) -> Transition:
        self.active = False
        if self.drives is not None:
            self.drives.hold()
        return SUCCESS

    def on_cleanup(self) -> Transition:
        self.active = False
        if self.drives is not None:
            self.drives.hold()
            self.drives.close()
        self.drives = self.grippers = None
        return SUCCESS

    def on_shutdown(self) -> Transition:
        return self.on_cleanup()

    def on_error(self) -> Transition:
        return self.on_deactivate()

    # --- cycle ---

    def write(self, time: float, period: float, command: Command | None) -> Result:
        d = self.drives
        if d is None:
            return _error('not configured')
        with d.lock:
            if d.faults:
                self.active = False
                return _error(f'{self._faults_text()}: holding; reset the faults, then activate')
            if command is None:
                return OK
            if not self.active:
                return _error('inactive: commands are not acted on')
            lengths = np.asarray(command.lengths, dtype=float)
            if lengths.shape != (6,) or not np.all(np.isfinite(lengths)):
                return _error(f'a command is 6 finite lengths [m], got {command.lengths!r}')
            outside = [f'{drive.name} {x:.4f} m' for drive, x in zip(d.drives, lengths)
                       if not drive.scale.within_limits(float(x))]
            if outside:
                return _error(f'outside the soft limits: {", ".join(outside)}')
            if command is not self._commanded:   # a new command: the SYNC cycle's setpoints take it
                self.setpoints.command(lengths, time, command.stamp)
                self._commanded, self._received = command, time
        return OK

    def read(self, time: float, period: float) -> SystemState:
        d = self.drives
        if d is None:
            return SystemState.no_sample()
        with d.lock:
            data = [d.data[drive.name] for drive in d.drives]
            faults, lost = dict(d.faults), d.bus_lost
            targets = np.array([drive.scale.position(drive.target) for drive in d.drives])
            statuses = tuple(ActuatorStatus(
                drive.name, enabled=p.state is State.OPERATION_ENABLED, homed=drive.homed,
                target_reached=bool(p.statusword & Statusword.TARGET_REACHED), fault=faults.get(drive.name))
                for drive, p in zip(d.drives, data))
            positions = np.array([drive.scale.position(p.position) for drive, p in zip(d.drives, data)])
            velocities = np.array([drive.scale.velocity(p.velocity) for drive, p in zip(d.drives, data)])
            efforts = np.array([drive.scale.force(p.torque) for drive, p in zip(d.drives, data)])
        if faults:
            self.active = False
        grippers = self.grippers.sensors() if self.grippers is not None else {ring: True for ring in RINGS}
        state = SystemState(
            positions=positions, velocities=velocities, efforts=efforts, targets=targets, grippers=grippers,
            actuators=statuses, bus=BusState.LOST if lost else BusState.OPERATIONAL, lost=lost,
            gripper_faults=tuple(f for name, f in faults.items() if name not in LEG_NAMES),
            rest_speed=max(drive.scale.rest_speed(d.period) for drive in d.drives))
        self._last = state
        return state

    # --- requests ---

    def hold(self) -> Result:
        if self.drives is None:
            return _error('not configured')
        with self.drives.lock:   # no SYNC steps the old setpoints between the hold and the new ones
            self.drives.hold()
            self._follow_targets()
        return OK

    def set_gripper(self, ring: str, close: bool) -> Result:
        d = self.drives
        if d is None or not self.active:
            return _error('refused: the hardware is inactive')
        with d.lock:
            if d.faults:
                return _error(f'refused: {self._faults_text()}')
            if self.grippers is None:
                return _error(f'refused: {ring} has no gripper on the bus')
            accepted, message = self.grippers.set(ring, close)
        return Result(ReturnType.OK if accepted else ReturnType.ERROR, message)

    def reset_faults(self) -> Result:
        d = self.drives
        if d is None:
            return _error('not configured')
        with d.lock:
            if d.bus_lost:
                return _error('the bus is lost: no fault reset')
            cleared = self._faults_text()
            if self.grippers is not None:
                stuck = self.grippers.resync()
                if stuck:
                    return _error(f'no fault reset: the clamp sensor of {", ".join(stuck)} disagrees with its output')
        reason = d.reset()
        if reason:
            return _error(reason)
        return Result(ReturnType.OK, f'reset {cleared}: activate to enable' if cleared else 'no fault')

    def status_values(self) -> dict:
        """The driver's ``target_latency_*`` fields (:class:`rrps_interfaces.driver.DriverStatus`)."""
        if self.drives is None:
            return {}
        with self.drives.lock:   # the SYNC cycle adds under it: the percentiles are taken outside
            recent = self.target_latency.copy()
        count, p50, p99, worst = recent.summary(time_now())
        if not count:
            return {}
        return {'target_latency_p50_ms': p50, 'target_latency_p99_ms': p99, 'target_latency_max_ms': worst}

    def _faults_text(self) -> str:
        return '; '.join(str(f) for f in self.drives.faults.values()) if self.drives is not None else ''
