#!/usr/bin/env python3
"""The command path's timing, hop by hop, as a new user launches the stack: idle and under load.

    python benchmarks/command_path.py [--seconds 40] [--hardware simulated|canopen]
                                      [--launch main,plain,docs] [--viewer-with-operator] [--no-step]
                                      [--climb-with-kinematics] [--computers]

The stack runs as docs/deployment.md lays it out, one process each: the driver
(``driver_node``, ``idle_rate`` = ``rate`` so that ``pose`` keeps 500 Hz at rest), the robot
computer (``rrps-compose ik_node fk_node`` and ``climb_node``; ``--climb-with-kinematics``: all
three composed, the same-run evidence of what a step's plan does to IK and FK), the operator
station's command path (``rrps-compose master_node teleop_node``, the master circling at 200 Hz)
and the viewer
(``viewer_node``; ``--viewer-with-operator``: composed with master and teleop, as the docs
said before: the same-run evidence of what its drawing does to them). With ``--hardware
canopen`` the driver drives the simulated CANopen drives (``rrps-drive-sim``, pinned to the
last CPU at a real-time priority above the driver's: devices with processors of their own). With
``--computers`` the machine stands for two computers: the robot's command path (the driver, IK,
FK and climb_node claim the first CPU) on one, the operator station, the viewer, the probe and
the drives on the last.

Launches, one after the other in the same run (``--launch``):

* ``main``: plain processes with ``rt_priority:=0`` (no node claims its scheduling: how every
  process ran when started without ``chrt``, the same-run baseline);
* ``plain``: plain processes (``ros2 run`` / ``rrps-compose``, no ``chrt``): the nodes claim their
  scheduling themselves (rrps_runtime.scheduling);
* ``docs``: the docs' launch, every process at its SCHED_RR priority from its start
  (``rrps_runtime.supervision.start_child``, as ``chrt -r`` and systemd's
  ``CPUSchedulingPolicy=rr`` do).

Each launch: ``--seconds`` of steady teleoperation idle, then as long under
``rrps_testing.load`` (a busy core, a DDS flood), then (under load) one climbing step, previewed
and executed. The operator probe (rrps_testing.command_trace, at SCHED_RR 40) holds the deadman
and records every hop; a SCHED_RR 45 canary shows stops of every real-time thread (RT
throttling). Prints per launch and phase: p50 / p99 / p99.9 / max of each hop and end to end,
the targets MET / MISSED, the load average beside them.
"""

from __future__ import annotations

import argparse
import os
import secrets
import sys
import threading
import time

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))

import numpy as np  # noqa: E402

from rrps_bringup.demo_processes import ROBOT_PROCESSES  # noqa: E402
from rrps_canopen.loopback_bus import free_port  # noqa: E402
from rrps_interfaces.driver import DriverStatus  # noqa: E402
from rrps_runtime.supervision import (  # noqa: E402
    CONTROL_NICE,
    CONTROL_RT_PRIORITY,
    OPERATOR_NICE,
    OPERATOR_RT_PRIORITY,
    start_child,
    stop_children,
)
from rrps_testing.command_trace import Canary, disengagements, gaps, hops, percentiles  # noqa: E402
from rrps_testing.load import Load  # noqa: E402

NAMESPACE = '/rrps'
OPERATOR_NODES = ('master_node', 'teleop_node', 'viewer_node')
#: (figure, target): the issue's targets, plain launch under load
TARGETS = {'target_pose gap p99 [ms]': 10.0, 'target_pose gap max [ms]': 50.0, 'slave_age_ms p99': 25.0,
           'disengaging statuses': 0, 'FK pose gap during a step, max [ms]': 20.0,
           'command -> its first SYNC p99 [ms]': 2.0}


def _command(nodes, *args: str) -> list[str]:
    if nodes == ('driver_node',):
        return [sys.executable, '-m', 'rrps_hardware.nodes.driver_node', *args]
    return [sys.executable, '-m', 'rrps_bringup.compose', *nodes, *args]


def start_stack(launch: str, hardware: str, port: int, viewer_with_operator: bool, can_port: int,
                climb_with_kinematics: bool = False, computers: bool = False) -> list:
    """The driver, the robot's and the operator's processes, launched as ``launch`` says; with
    ``computers`` the robot's command path on the first CPU, the operator station's on the last."""
    common = ['--ros-args', '-r', f'__ns:={NAMESPACE}', '-p', 'robot:=pole_climber']
    if launch == 'main':
        common += ['-p', 'rt_priority:=0']
    env = dict(os.environ, RRPS_CAN_PORT=str(can_port))
    viewer_apart = not viewer_with_operator
    operator = OPERATOR_NODES[:2] if viewer_apart else OPERATOR_NODES
    viewer = ['-p', f'port:={port}', '-p', f'token:={secrets.token_urlsafe(12)}']
    robot_cpu, operator_cpu = (['-p', 'cpu_affinity:=[0]'], ['-p', f'cpu_affinity:=[{os.cpu_count() - 1}]']) \
        if computers else ([], [])
    processes = [
        (('driver_node',), ['-p', 'auto_activate:=true', '-p', f'hardware:={hardware}', '-p', 'idle_rate:=500.0',
                            *robot_cpu], (CONTROL_NICE, CONTROL_RT_PRIORITY)),
        *[(nodes, robot_cpu, (CONTROL_NICE, CONTROL_RT_PRIORITY)) for nodes in
          ([sum(ROBOT_PROCESSES.values(), ())] if climb_with_kinematics else ROBOT_PROCESSES.values())],
        (operator, ['-p', 'trajectory:=circle', *operator_cpu] + ([] if viewer_apart else viewer),
         (OPERATOR_NICE, OPERATOR_RT_PRIORITY)),
    ] + ([(('viewer_node',), viewer + operator_cpu, (OPERATOR_NICE, None))] if viewer_apart else [])
    children = []
    for nodes, extra, (nice, realtime) in processes:
        scheduling = {'nice': nice, 'realtime': realtime} if launch == 'docs' else {}
        children.append(start_child(_command(nodes, *common, *extra), env=env, **scheduling))
    return children


def _step(trace, canary, seconds: float) -> dict:
    """Release the deadman, climb one step up; FK pose gaps from the request to the step's end,
    the worst three traced: the stamps of the driver's states in FK's poses around them (as far
    apart as the gap: FK or the driver stalled; less: the transport held poses), the driver's
    ``grippers/state`` messages received meanwhile (some: the driver ran) and the canary's stops."""
    from std_srvs.srv import Trigger
    trace.holding = False
    deadline = time.monotonic() + 10.0
    while trace.engaged() and time.monotonic() < deadline:
        time.sleep(0.05)
    client = trace.create_client(Trigger, 'climb/step_up')
    if not client.wait_for_service(timeout_sec=10.0):
        return {'error': 'no climb/step_up'}
    t0, m0 = trace.now(), time.monotonic()
    future = client.call_async(Trigger.Request())
    while not future.done() and trace.now() - t0 < 30.0:
        time.sleep(0.02)
    if not (future.done() and future.result().success):
        return {'error': f'step refused: {future.result().message if future.done() else "no answer"}'}
    while trace.climb_state != 'executing' and trace.now() - t0 < seconds:
        time.sleep(0.05)
    while trace.climb_state == 'executing' and trace.now() - t0 < seconds:
        time.sleep(0.05)
    t1 = trace.now()
    poses = trace.between('pose', t0, t1)
    g = gaps(poses[:, 0]) if len(poses) > 1 else np.array([])
    worst = np.sort(g)[-3:][::-1] if g.size else []
    log = [f'{t - t0:.1f} s {state}: {detail[:80]}' for t, state, detail in trace.climb_log if t >= t0]
    traced = []
    for i in (np.argsort(g)[-3:][::-1] if g.size else []):
        at = poses[i + 1, 0] - t0
        stops = canary.stops(m0 + at - 0.2, m0 + at + 0.05, longer_than=0.005)
        stamped = 1e3 * (poses[i + 1, 1] - poses[i, 1])
        heard = len(trace.between('grippers/state', poses[i, 0], poses[i + 1, 0]))
        traced.append(f'{g[i]:.1f} ms at {at:.2f} s: poses of states stamped {stamped:.1f} ms apart; '
                      f'{heard} grippers/state meanwhile; canary stops there '
                      f'{", ".join(f"{1e3 * x:.0f}" for x in stops) or "none"} [ms]')
    return {'gap_max': float(g.max()) if g.size else np.nan, 'worst': worst, 'seconds': t1 - t0,
            'state': trace.climb_state, 'poses': len(poses), 'log': log, 'traced': traced,
            'worst_at': [float(poses[i + 1, 0] - t0) for i in np.argsort(g)[-3:][::-1]] if g.size else []}


def measure(trace, canary, seconds: float, sim, clock_offset: float) -> dict:
    """One phase of steady teleoperation: every figure over ``seconds``."""
    trace.holding = True
    deadline = time.monotonic() + 60.0
    while not trace.engaged() and time.monotonic() < deadline:
        time.sleep(0.05)
    engaged = trace.engaged()
    if sim is not None:
        sim.ask(cmd='trace', on=True)
    time.sleep(5.0)  # past the engagement and the start-up of the processes' workers
    t0, m0 = trace.now(), time.monotonic()
    windows = []   # the driver's status every 10 s: its target latency is over the last 10 s
    while (left := m0 + seconds - time.monotonic()) > 0.0:
        time.sleep(min(10.0, left))
        windows.append(DriverStatus.from_values(trace.values('driver_node')))
    t1, m1 = trace.now(), time.monotonic()
    drive_targets = None
    if sim is not None:
        rows = sim.ask(cmd='trace', on=False)['trace']
        drive_targets = np.array([(r[0] + clock_offset, r[1][0]) for r in rows]).reshape(-1, 2)
    ages = [a for t, _, _, a in list(trace.statuses) if t0 <= t <= t1 and a is not None]
    targets, grippers = trace.between('target_pose', t0, t1), trace.between('grippers/state', t0, t1)
    return {'hops': hops(trace, t0, t1, drive_targets), 'target_gaps': gaps(targets[:, 0]) if len(targets) else [],
            'gripper_gaps': gaps(grippers[:, 0]) if len(grippers) else [],
            'gripper_late': late_grippers(grippers),
            'slave_age': ages, 'disengaged': disengagements(trace, t0, t1), 'rt_stops': canary.stops(m0, m1),
            'load': os.getloadavg()[0], 'ik': trace.values('ik_node'), 'driver': trace.values('driver_node'),
            'engaged': engaged, 'first_sync': [(w.target_latency_p99_ms, w.target_latency_max_ms) for w in windows
                                               if w.target_latency_p99_ms is not None]}


def late_grippers(records: np.ndarray, late: float = 0.075) -> list[tuple[float, float]]:
    """For each grippers/state received more than ``late`` s after the one before: (the gap between
    their stamps, the late one's receipt minus its stamp) [ms]. A stamp gap near the gap: published
    late; a delivery near it: published on time, delivered late (e.g. a reliable repair)."""
    out = []
    for (r0, s0), (r1, s1) in zip(records[:-1, :2], records[1:, :2]):
        if r1 - r0 > late:
            out.append((1e3 * (s1 - s0), 1e3 * (r1 - s1)))
    return out


def run_launch(launch: str, args) -> dict:
    import rclpy

    from rrps_runtime.process import make_executor, spin_until_shutdown
    from rrps_testing.canopen_rig import DriveSim
    from rrps_testing.command_trace import CommandTrace, claim_probe

    can_port = free_port()
    sim = DriveSim('pole_climber', port=can_port, cpus=(os.cpu_count() - 1,)) if args.hardware == 'canopen' else None
    children = start_stack(launch, args.hardware, free_port(), args.viewer_with_operator, can_port,
                           args.climb_with_kinematics, args.computers)
    context = rclpy.Context()
    rclpy.init(context=context)
    trace = CommandTrace(context=context, namespace=NAMESPACE)
    executor = make_executor(context, 'events')
    executor.add_node(trace)
    stop = threading.Event()

    def spin() -> None:
        claim_probe(executor, cpus=(os.cpu_count() - 1,) if args.computers else ())
        spin_until_shutdown(executor, context, stop, period=0.02)
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    results = {}
    offset = time.time() - time.monotonic()
    try:
        with Canary() as canary:
            results['idle'] = measure(trace, canary, args.seconds, sim, offset)
            with Load(busy=1, flood_rate=2000.0, quiet=True):
                time.sleep(3.0)
                results['load'] = measure(trace, canary, args.seconds, sim, offset)
                if not args.no_step:
                    results['step'] = _step(trace, canary, 180.0)
        results['alive'] = all(c.poll() is None for c in children)
    finally:
        stop.set()
        spinner.join(10.0)
        trace.destroy_node()
        rclpy.try_shutdown(context=context)
        stop_children(children)
        if sim is not None:
            sim.stop()
    return results


def _ms(text: str | None) -> str:
    """A reported age [ms] to one decimal, '-' when the node did not report it."""
    return f'{float(text):.1f}' if text else '-'


def report(launch: str, results: dict, hardware: str) -> list[str]:
    """Print the hop table and the target figures of one launch; the verdict lines."""
    print(f'\n### {launch} launch ({hardware})\n')
    print('| phase | hop | n | p50 [ms] | p99 [ms] | p99.9 [ms] | max [ms] |')
    print('|---|---|---|---|---|---|---|')
    for phase in ('idle', 'load'):
        r = results[phase]
        for name, values in r['hops'].items():
            n, p50, p99, p999, mx = percentiles(values)
            print(f'| {phase} | {name} | {n} | {p50:.2f} | {p99:.2f} | {p999:.2f} | {mx:.2f} |')
        if r['first_sync']:   # the driver's own figure, its worst 10-s window
            p99, mx = (max(w[i] for w in r['first_sync']) for i in (0, 1))
            print(f'| {phase} | driver: command -> its first SYNC (worst of {len(r["first_sync"])} 10-s windows) '
                  f'| | | {p99:.2f} | | {mx:.2f} |')
    figures = {}
    print('\n| phase | load avg | target_pose gap p99 / max [ms] | slave_age_ms p99 | disengaging | '
          'RT stops > 20 ms | IK / driver command age p99 [ms] | grippers/state gap p99 / max [ms] | '
          'late grippers/state: stamp gap / delivery [ms] |')
    print('|---|---|---|---|---|---|---|---|---|')
    for phase in ('idle', 'load'):
        r = results[phase]
        _, _, gp99, _, gmax = percentiles(r['target_gaps'])
        age99 = percentiles(r['slave_age'])[2]
        dis = sum(r['disengaged'].values())
        stops = r['rt_stops']
        if not r['engaged']:  # every figure of the phase MISSED
            print(f'| {phase} | {r["load"]:.1f} | teleop did not engage in 60 s; driver faults: '
                  f'{r["driver"].get("faults")} |')
            if phase == 'load':
                figures.update({name: np.nan for name in list(TARGETS)[:4]})
                if hardware == 'canopen':
                    figures['command -> its first SYNC p99 [ms]'] = np.nan
            continue
        print(f'| {phase} | {r["load"]:.1f} | {gp99:.1f} / {gmax:.1f} | {age99:.1f} | {dis} '
              f'{dict(r["disengaged"]) or ""} | {len(stops)}{f" (max {1e3 * max(stops):.0f} ms)" if stops else ""} | '
              f'{_ms(r["ik"].get("command_age_p99_ms"))} / {_ms(r["driver"].get("command_age_p99_ms"))} | '
              f'{percentiles(r["gripper_gaps"])[2]:.1f} / {percentiles(r["gripper_gaps"])[4]:.1f} | '
              f'{", ".join(f"{g:.0f} / {d:.0f}" for g, d in r["gripper_late"][:8]) or "none"} |')
        if phase == 'load':
            figures.update({'target_pose gap p99 [ms]': gp99, 'target_pose gap max [ms]': gmax,
                            'slave_age_ms p99': age99, 'disengaging statuses': dis})
            if hardware == 'canopen':
                figures['command -> its first SYNC p99 [ms]'] = max((w[0] for w in r['first_sync']), default=np.nan)
    step = results.get('step')
    if step:
        if 'error' in step:
            print(f'\nclimbing step under load: {step["error"]}')
        else:
            worst = ', '.join(f'{w:.1f}' for w in step['worst'])
            at = ', '.join(f'{w:.1f}' for w in step['worst_at'])
            print(f'\nclimbing step under load: {step["seconds"]:.1f} s ({step["state"]}), {step["poses"]} poses, '
                  f'largest FK pose gaps {worst} ms, ending {at} s after the request; climb/status:')
            for line in step['log']:
                print(f'    {line}')
            print('  the largest gaps:')
            for line in step['traced']:
                print(f'    {line}')
            figures['FK pose gap during a step, max [ms]'] = step['gap_max']
    lines = []
    for name, value in figures.items():
        target = TARGETS[name]
        met = bool(value <= target)
        lines.append(f'{launch}: {"MET" if met else "MISSED"}: {name} {value:.1f} (target <= {target})')
    return lines


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--seconds', type=float, default=40.0, help='steady teleoperation per phase')
    p.add_argument('--hardware', choices=('simulated', 'canopen'), default='simulated')
    p.add_argument('--launch', default='main,plain,docs', help='comma-separated: main, plain, docs')
    p.add_argument('--viewer-with-operator', action='store_true',
                   help='the viewer composed with master and teleop (default: a process of its own)')
    p.add_argument('--no-step', action='store_true', help='no climbing step after the loaded phase')
    p.add_argument('--climb-with-kinematics', action='store_true',
                   help='climb_node composed with IK and FK (default: a process of its own, as the demo runs it)')
    p.add_argument('--computers', action='store_true',
                   help="the robot computer's command path (driver, IK, FK, climb) on the first CPU; the operator "
                        'station, the viewer and the probe on the last, beside the drives')
    args = p.parse_args()
    launches = [x for x in args.launch.split(',') if x]
    print(f'# command path, {args.hardware}, {os.cpu_count()} CPUs, {args.seconds:.0f} s per phase, '
          f'viewer {"with master and teleop" if args.viewer_with_operator else "in a process of its own"}, '
          f'climb_node {"with IK and FK" if args.climb_with_kinematics else "in a process of its own"}, '
          f'{"robot on CPU 0, the rest on the last CPU, " if args.computers else ""}'
          f'load average {os.getloadavg()[0]:.1f} at start')
    verdicts = []
    for launch in launches:
        results = run_launch(launch, args)
        verdicts += report(launch, results, args.hardware)
        sys.stdout.flush()
    print()
    for line in verdicts:
        print(line)
    return 0 if all(line.startswith('plain: MET') for line in verdicts if line.startswith('plain')) else 1


if __name__ == '__main__':
    sys.exit(main())
