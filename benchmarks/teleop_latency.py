#!/usr/bin/env python3
"""Teleop latency: master state -> teleop_node -> slave ``actuators/command`` (p50/p99).

    python benchmarks/teleop_latency.py [--samples 1000] [--no-processes]

One sample: the bench publishes a master sample (``master/actuators/state`` and ``master/pose``,
alternating between two poses 2 µm apart, so every sample changes the slave's command by 8 µm,
inside every speed limit) and waits for the first ``actuators/command`` whose lengths differ from
the previous one. Runs, interleaved sample by sample so they share the machine's load:

* in-process (one EventsExecutor, every node in one process):
  - baselines: bare rclpy pub -> sub of a JointState (1 delivery), pub -> relay -> sub
    (2 deliveries) and pub -> relay -> relay -> sub (3 deliveries);
  - joint mode: master/actuators/state -> teleop_node -> actuators/command (2 deliveries);
  - Cartesian mode: master/pose -> teleop_node -> target_pose -> ik_node -> actuators/command
    (3 deliveries);
  - Cartesian mode with ``control=timer`` at 200 Hz (the alternative to message-triggered control);
  - Cartesian mode with ``jerk_limited`` off (the guarded commands as they are, without the
    jerk-limited stream: what the stream costs);
* across processes (the installed executables, each its own EventsExecutor; the bench is a
  separate process, so every number is a round trip from and back to the bench):
  - baseline: bare echo process, bench -> echo -> bench (2 deliveries);
  - joint mode: bench -> teleop_node -> bench (2 deliveries);
  - Cartesian mode: bench -> teleop_node -> ik_node -> bench (3 deliveries).

The targets (p99 <= 1.5x the baseline's) are printed twice: as the target words them (joint mode
against 1 delivery, Cartesian against 2: each chain has one delivery more than its baseline),
and against the bare chain of the same topology, which isolates what the mapping and its
guards cost from what the transport costs.
Loopback only (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) with a private ROS_DOMAIN_ID.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from geometry_msgs.msg import PoseStamped  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Bool  # noqa: E402

from rrps_description.geometry import load_robot
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.nodes.ik_node import IkNode  # noqa: E402
from rrps_runtime.messages import joint_state_msg, pose_to_msg
from rrps_runtime.process import make_executor, run_nodes, spin_until_shutdown
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
from rrps_teleop.nodes.teleop_node import TeleopNode  # noqa: E402
from rrps_testing.processes import stop_processes, wait_until  # noqa: E402

MASTER = load_robot('master_robot')
SLAVE = load_robot('pole_climber')
#: Far above any stall of a loaded machine: each teleop_node engages once for the whole run.
TELEOP = {'master_timeout': 5.0, 'enable_timeout': 5.0}
STEP = 2e-6  # master displacement between the two alternating samples [m]


class Echo(Node):
    """Bare relay: ``source`` -> ``sink`` (default bench/ping -> bench/pong), republishing each message."""

    def __init__(self, source: str = 'bench/ping', sink: str = 'bench/pong', *, name: str = 'bench_echo',
                 **kwargs):
        super().__init__(name, **kwargs)
        pub = self.create_publisher(JointState, sink, COMMAND_QOS)
        self.create_subscription(JointState, source, pub.publish, COMMAND_QOS)


class Waiter:
    """Sets an event at the first JointState whose positions differ from the previous one."""

    def __init__(self):
        self.event = threading.Event()
        self.armed = False
        self.last: tuple | None = None
        self.received = 0.0

    def __call__(self, msg: JointState) -> None:
        value = tuple(msg.position)
        changed = value != self.last
        self.last = value
        if self.armed and changed:
            self.received = time.perf_counter()
            self.armed = False
            self.event.set()


@dataclass
class Run:
    """One measured path: ``send(k)`` publishes sample k and returns the time of the trigger publish."""

    name: str
    send: Callable[[int], float]
    waiter: Waiter
    latencies: list = field(default_factory=list)
    lost: int = 0


def master_samples() -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The two alternating master samples: (position, quaternion, lengths)."""
    out = []
    for dx in (0.0, STEP):
        p = MASTER.home_position + [dx, 0.0, 0.0]
        q = MASTER.home_quaternion_xyzw
        out.append((p, q, inverse_kinematics(MASTER, p, q).lengths))
    return out


def teleop_sender(node: Node, namespace: str, trigger: str) -> Callable[[int], float]:
    """Publishes master/actuators/state and master/pose under ``namespace``; the trigger topic last."""
    state_pub = node.create_publisher(JointState, f'{namespace}/master/actuators/state', STATE_QOS)
    pose_pub = node.create_publisher(PoseStamped, f'{namespace}/master/pose', STATE_QOS)
    samples = master_samples()

    def send(k: int) -> float:
        p, q, lengths = samples[k % 2]
        stamp = node.get_clock().now().to_msg()
        state = joint_state_msg(stamp, lengths)
        pose = pose_to_msg(p, q, frame_id='master_ring_a', stamp=stamp)
        if trigger == 'pose':
            state_pub.publish(state)
            t0 = time.perf_counter()
            pose_pub.publish(pose)
        else:
            pose_pub.publish(pose)
            t0 = time.perf_counter()
            state_pub.publish(state)
        return t0
    return send


def bare_sender(node: Node, topic: str) -> Callable[[int], float]:
    pub = node.create_publisher(JointState, topic, COMMAND_QOS)
    samples = master_samples()

    def send(k: int) -> float:
        msg = joint_state_msg(node.get_clock().now().to_msg(), samples[k % 2][2])
        t0 = time.perf_counter()
        pub.publish(msg)
        return t0
    return send


def operator(node: Node, namespaces: list[str]) -> Callable[[], None]:
    """The deadman (teleop/enable true) and the slave's pose at home, for every teleop_node."""
    enables = [node.create_publisher(Bool, f'{ns}/teleop/enable', COMMAND_QOS) for ns in namespaces]
    poses = [node.create_publisher(PoseStamped, f'{ns}/pose', STATE_QOS) for ns in namespaces]

    def tick() -> None:
        stamp = node.get_clock().now().to_msg()
        for pub in enables:
            pub.publish(Bool(data=True))
        for pub in poses:
            pub.publish(pose_to_msg(SLAVE.home_position, SLAVE.home_quaternion_xyzw, frame_id='ring_a',
                                    stamp=stamp))
    return tick


def measure(runs: list[Run], samples: int, warmup: int = 100, timeout: float = 0.5) -> None:
    """Interleave one sample of each run at a time."""
    for i in range(samples + warmup):
        for run in runs:
            run.waiter.event.clear()
            run.waiter.armed = True
            t0 = run.send(i)
            ok = run.waiter.event.wait(timeout)
            run.waiter.armed = False
            if i >= warmup:
                if ok:
                    run.latencies.append(run.waiter.received - t0)
                else:
                    run.lost += 1


def spin_in_thread(context, nodes):
    executor = make_executor(context, 'events')
    for node in nodes:
        executor.add_node(node)
    stop = threading.Event()
    thread = threading.Thread(target=spin_until_shutdown, args=(executor, context, stop),
                              kwargs={'period': 0.01}, daemon=True)
    thread.start()
    return stop, thread


def prime(runs: list[Run], operator_tick, seconds: float = 20.0) -> None:
    """Hold the deadman and send samples until every run answers (all teleop nodes engaged)."""
    deadline = time.monotonic() + seconds
    pending = list(runs)
    k = 0
    while pending and time.monotonic() < deadline:
        operator_tick()
        for run in list(pending):
            run.waiter.event.clear()
            run.waiter.armed = True
            run.send(k)
            if run.waiter.event.wait(0.05):
                pending.remove(run)
            run.waiter.armed = False
        k += 1
    if pending:
        raise RuntimeError(f'no answer from {[r.name for r in pending]}')


def keep_operator(operator_tick, stop: threading.Event) -> None:
    """Hold the deadman at 20 Hz from a thread until ``stop`` is set."""
    def loop():
        while not stop.wait(0.05):
            operator_tick()
    threading.Thread(target=loop, daemon=True).start()


def in_process(samples: int, domain_id: int) -> list[Run]:
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    over = lambda **kv: [Parameter(k, value=v) for k, v in (TELEOP | kv).items()]  # noqa: E731
    nodes = [TeleopNode(context=context, namespace='/joint', parameter_overrides=over(mode='joint')),
             TeleopNode(context=context, namespace='/cart', parameter_overrides=over(mode='cartesian')),
             IkNode(context=context, namespace='/cart'),
             TeleopNode(context=context, namespace='/raw', parameter_overrides=over(mode='cartesian',
                                                                                   jerk_limited=False)),
             IkNode(context=context, namespace='/raw'),
             TeleopNode(context=context, namespace='/timer',
                        parameter_overrides=over(mode='cartesian', control='timer', control_rate=200.0)),
             IkNode(context=context, namespace='/timer'),
             Echo(context=context, namespace='/relay'),
             Echo(context=context, namespace='/relay2'),
             Echo('bench/pong', 'bench/out', name='bench_echo_2', context=context, namespace='/relay2')]
    bench = Node('bench', context=context)
    sender = Node('bench_sender', context=context)
    runs = [Run('bare pub->sub, 1 delivery (baseline)', bare_sender(sender, '/bare/bench/ping'), Waiter()),
            Run('bare pub->relay->sub, 2 deliveries (baseline)', bare_sender(sender, '/relay/bench/ping'),
                Waiter()),
            Run('bare pub->relay->relay->sub, 3 deliveries (baseline)',
                bare_sender(sender, '/relay2/bench/ping'), Waiter()),
            Run('joint mode: pub->teleop->sub, 2 deliveries', teleop_sender(sender, '/joint', 'state'), Waiter()),
            Run('Cartesian mode: pub->teleop->ik->sub, 3 deliveries', teleop_sender(sender, '/cart', 'pose'),
                Waiter()),
            Run('Cartesian, control=timer 200 Hz: teleop + ik', teleop_sender(sender, '/timer', 'pose'),
                Waiter()),
            Run('Cartesian mode, guarded commands as they are (jerk_limited off)',
                teleop_sender(sender, '/raw', 'pose'), Waiter())]
    for run, topic in zip(runs, ('/bare/bench/ping', '/relay/bench/pong', '/relay2/bench/out',
                                 '/joint/actuators/command', '/cart/actuators/command',
                                 '/timer/actuators/command', '/raw/actuators/command')):
        bench.create_subscription(JointState, topic, run.waiter, COMMAND_QOS)
    tick = operator(sender, ['/joint', '/cart', '/timer', '/raw'])
    stop, thread = spin_in_thread(context, nodes + [bench, sender])
    op_stop = threading.Event()
    try:
        prime(runs, tick)
        keep_operator(tick, op_stop)
        measure(runs, samples)
        return runs
    finally:
        op_stop.set()
        stop.set()
        thread.join(5.0)
        for node in nodes + [bench, sender]:
            node.destroy_node()
        rclpy.shutdown(context=context)


def across_processes(samples: int, domain_id: int) -> list[Run]:
    bindir = Path(sys.executable).parent
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id))

    def ros(ns: str, **params) -> list[str]:
        return ['--ros-args', '-r', f'__ns:={ns}'] + sum(
            (['-p', f'{k}:={v}'] for k, v in (TELEOP | params).items()), [])
    commands = [[str(bindir / 'teleop_node'), *ros('/joint', mode='joint')],
                [str(bindir / 'teleop_node'), *ros('/cart', mode='cartesian')],
                [str(bindir / 'ik_node'), '--ros-args', '-r', '__ns:=/cart'],
                [sys.executable, __file__, '--echo', '--ros-args', '-r', '__ns:=/relay']]
    processes = [subprocess.Popen(c, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
                 for c in commands]
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    bench = Node('bench', context=context)
    runs = [Run('bare echo round trip, 2 deliveries (baseline)', bare_sender(bench, '/relay/bench/ping'), Waiter()),
            Run('joint mode: bench -> teleop -> bench, 2 deliveries', teleop_sender(bench, '/joint', 'state'),
                Waiter()),
            Run('Cartesian mode: bench -> teleop -> ik -> bench, 3 deliveries', teleop_sender(bench, '/cart', 'pose'),
                Waiter())]
    for run, topic in zip(runs, ('/relay/bench/pong', '/joint/actuators/command', '/cart/actuators/command')):
        bench.create_subscription(JointState, topic, run.waiter, COMMAND_QOS)
    tick = operator(bench, ['/joint', '/cart'])
    stop, thread = spin_in_thread(context, [bench])
    op_stop = threading.Event()
    try:
        if not wait_until(lambda: all(bench.count_subscribers(t) for t in (
                '/relay/bench/ping', '/joint/master/actuators/state', '/cart/master/pose', '/cart/target_pose')), 30):
            raise RuntimeError('the processes did not come up')
        prime(runs, tick)
        keep_operator(tick, op_stop)
        measure(runs, samples)
        return runs
    finally:
        op_stop.set()
        stop.set()
        thread.join(5.0)
        bench.destroy_node()
        rclpy.shutdown(context=context)
        stop_processes(processes)


def row(run: Run) -> str:
    us = np.array(run.latencies) * 1e6
    if not len(us):
        return f'| {run.name} | 0 | {run.lost} | - | - | - |'
    return (f'| {run.name} | {len(us)} | {run.lost} | {np.percentile(us, 50):.0f} | '
            f'{np.percentile(us, 99):.0f} | {np.max(us):.0f} |')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--samples', type=int, default=1000)
    parser.add_argument('--no-processes', action='store_true')
    parser.add_argument('--echo', action='store_true', help=argparse.SUPPRESS)
    args, ros_args = parser.parse_known_args()
    if args.echo:
        run_nodes([Echo], ['echo', *ros_args])
        return
    domain_id = 100 + os.getpid() % 100
    print(f'# teleop latency: master sample -> actuators/command ({platform.machine()}, {os.cpu_count()} cores, '
          f'Python {platform.python_version()}, {args.samples} samples each, '
          f'load average {os.getloadavg()[0]:.1f} at start)\n')
    print('| run | samples | lost | p50 [us] | p99 [us] | max [us] |')
    print('|---|---|---|---|---|---|')
    runs = in_process(args.samples, domain_id)
    for run in runs:
        print(row(run).replace('| ', '| in-process: ', 1))
    sys.stdout.flush()
    if not args.no_processes:
        for run in across_processes(args.samples, domain_id + 1):
            print(row(run).replace('| ', '| processes: ', 1))
    bare, relay, relay2, joint, cart, timer, raw = (np.percentile(r.latencies, 99) * 1e3 for r in runs)
    print(f'\nin-process p99: joint mode adds {joint - relay:.3f} ms over the bare relay of the same topology '
          f'(2 deliveries); Cartesian mode adds {cart - relay2:.3f} ms over the two-relay chain (3 deliveries); '
          f'control=timer adds {timer - cart:.3f} ms over message-triggered control; the jerk-limited stream '
          f'adds {cart - raw:.3f} ms over the guarded commands as they are.')
    ok = True
    for what, ours, baseline in (
            ('joint mode (teleop) vs bare 1 delivery [target as stated]', joint, bare),
            ('Cartesian mode (teleop + ik) vs bare relay, 2 deliveries [target as stated]', cart, relay),
            ('joint mode vs bare relay, same topology (2 deliveries)', joint, relay),
            ('Cartesian mode vs bare two-relay chain, same topology (3 deliveries)', cart, relay2)):
        met = ours <= TARGET_RATIO * baseline
        ok &= met
        print(f'{what}: p99 {ours:.3f} ms / {baseline:.3f} ms = {ours / baseline:.2f} '
              f'(target <= {TARGET_RATIO}): {"MET" if met else "MISSED"}')
    return 0 if ok else 1


#: The teleop step's p99 may be at most this multiple of the bare transport's p99 (same run).
TARGET_RATIO = 1.5


if __name__ == '__main__':
    sys.exit(main())
