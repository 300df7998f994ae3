#!/usr/bin/env python3
"""Latency of the node chain target_pose -> ik_node -> driver_node -> fk_node -> pose.

    python benchmarks/chain_latency.py [--samples 2000] [--executor events|single|both] [--no-processes]

One sample: publish a target_pose and wait for the ``pose`` that returns it (within 1e-6 m and
1e-6 rad; successive targets differ by >= 1 mm, so the match is unambiguous). The driver runs
with ``publish_on_command`` and no lag or speed limit, so the matching pose is the one caused by
this target; its 500 Hz timer keeps running (and loading the executor) meanwhile.

Baselines measured in the same run, interleaved sample by sample with the chain:
* in-process: bare rclpy pub -> sub of a PoseStamped between two nodes in the same executor
  (same kind) as the chain, with the chain's nodes spinning alongside;
* across processes: a round trip through an echo process (bare rclpy sub -> pub), 2 hops,
  next to the chain's 4 hops through the installed executables (EventsExecutor in each).
Target: in-process, the chain adds <= 1 ms p99 over the bare pub -> sub baseline.
Runs on loopback with a private ROS_DOMAIN_ID.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import threading
import time
from pathlib import Path

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from geometry_msgs.msg import PoseStamped  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_hardware.nodes.driver_node import DriverNode  # noqa: E402
from rrps_kinematics import check_pose
from rrps_kinematics.nodes.fk_node import FkNode  # noqa: E402
from rrps_kinematics.nodes.ik_node import IkNode  # noqa: E402
from rrps_runtime.messages import pose_from_msg, pose_to_msg
from rrps_runtime.process import make_executor, run_nodes, spin_until_shutdown
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
from rrps_testing.processes import stop_processes, wait_until  # noqa: E402

NAMESPACE = '/rrps_bench'
IDEAL_DRIVER = {'time_constant': 0.0, 'limit_speed': False, 'publish_on_command': True,
                'auto_activate': True}
MATCH = 1e-6


class Echo(Node):
    """Bare relay for the cross-process baseline: bench/ping -> bench/pong."""

    def __init__(self, **kwargs):
        super().__init__('bench_echo', **kwargs)
        pub = self.create_publisher(PoseStamped, 'bench/pong', COMMAND_QOS)
        self.create_subscription(PoseStamped, 'bench/ping', pub.publish, COMMAND_QOS)


def targets(n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """n valid poses around home; successive ones differ by >= 1 mm."""
    g = load_robot('pole_climber')
    out = []
    k = 0
    while len(out) < n:
        p = g.home_position + 0.001 * np.array([(k % 7) - 3, (k % 5) - 2, (k % 2) * 2 + (k % 3)])
        q = rotation_vector_to_quat_xyzw(0.002 * np.array([k % 3, (k + 1) % 3, 0.0]))
        k += 1
        if out and np.linalg.norm(p - out[-1][0]) < 1e-3:
            continue
        if check_pose(g, p, q)[0]:
            out.append((p, q))
    return out


class Waiter:
    """Sets an event when a message matching the expected pose arrives; records its time."""

    def __init__(self):
        self.event = threading.Event()
        self.expected: tuple[np.ndarray, np.ndarray] | None = None
        self.received = 0.0

    def __call__(self, msg: PoseStamped) -> None:
        expected = self.expected
        if expected is None:
            return
        p, q = pose_from_msg(msg)
        if np.max(np.abs(p - expected[0])) < MATCH and min(np.max(np.abs(q - expected[1])),
                                                           np.max(np.abs(q + expected[1]))) < MATCH:
            self.received = time.perf_counter()
            self.expected = None
            self.event.set()


def measure(pub, waiter: Waiter, pose, stamp_node, timeout: float = 0.5) -> float | None:
    """Latency [s] of one publish -> matching receipt, or None when lost."""
    waiter.event.clear()
    waiter.expected = pose
    msg = pose_to_msg(*pose, frame_id='ring_a', stamp=stamp_node.get_clock().now().to_msg())
    t0 = time.perf_counter()
    pub.publish(msg)
    if not waiter.event.wait(timeout):
        waiter.expected = None
        return None
    return waiter.received - t0


def interleaved(runs, poses, samples: int, warmup: int = 100) -> list[tuple[np.ndarray, int]]:
    """Alternate one sample of each (pub, waiter, node) run; [(latencies [s], lost), ...]."""
    lat = [[] for _ in runs]
    lost = [0 for _ in runs]
    for i in range(samples + warmup):
        pose = poses[i % len(poses)]
        for k, (pub, waiter, node) in enumerate(runs):
            t = measure(pub, waiter, pose, node)
            if i < warmup:
                continue
            if t is None:
                lost[k] += 1
            else:
                lat[k].append(t)
    return [(np.array(x), n) for x, n in zip(lat, lost)]


def in_process(kind: str, samples: int, poses, domain_id: int):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    kw = dict(context=context, namespace=NAMESPACE)
    nodes = [IkNode(**kw), FkNode(**kw),
             DriverNode(**kw, parameter_overrides=[Parameter(k, value=v) for k, v in IDEAL_DRIVER.items()])]
    bench = Node('bench', **kw)
    sender = Node('bench_sender', **kw)
    chain_waiter, bare_waiter = Waiter(), Waiter()
    bench.create_subscription(PoseStamped, 'pose', chain_waiter, STATE_QOS)
    bench.create_subscription(PoseStamped, 'bench/bare', bare_waiter, COMMAND_QOS)
    target_pub = bench.create_publisher(PoseStamped, 'target_pose', COMMAND_QOS)
    bare_pub = sender.create_publisher(PoseStamped, 'bench/bare', COMMAND_QOS)
    executor = make_executor(context, kind)
    for node in nodes + [bench, sender]:
        executor.add_node(node)
    stop = threading.Event()
    thread = threading.Thread(target=spin_until_shutdown, args=(executor, context, stop),
                              kwargs={'period': 0.01}, daemon=True)
    thread.start()
    try:
        if not wait_until(lambda: target_pub.get_subscription_count() and bare_pub.get_subscription_count(), 10):
            raise RuntimeError('in-process discovery failed')
        return interleaved([(bare_pub, bare_waiter, bench), (target_pub, chain_waiter, bench)], poses, samples)
    finally:
        stop.set()
        thread.join(5.0)
        for node in nodes + [bench, sender]:
            node.destroy_node()
        rclpy.shutdown(context=context)


def across_processes(samples: int, poses, domain_id: int):
    bindir = Path(sys.executable).parent
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id))
    ros = ['--ros-args', '-r', f'__ns:={NAMESPACE}', '-p', 'robot:=pole_climber']
    commands = [[str(bindir / 'ik_node'), *ros], [str(bindir / 'fk_node'), *ros],
                [str(bindir / 'driver_node'), *ros, *sum((['-p', f'{k}:={str(v).lower()}']
                                                        for k, v in IDEAL_DRIVER.items()), [])],
                [sys.executable, __file__, '--echo', *ros[:3]]]
    processes = [subprocess.Popen(c, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
                 for c in commands]
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    bench = Node('bench', context=context, namespace=NAMESPACE)
    chain_waiter, echo_waiter = Waiter(), Waiter()
    bench.create_subscription(PoseStamped, 'pose', chain_waiter, STATE_QOS)
    bench.create_subscription(PoseStamped, 'bench/pong', echo_waiter, COMMAND_QOS)
    target_pub = bench.create_publisher(PoseStamped, 'target_pose', COMMAND_QOS)
    ping_pub = bench.create_publisher(PoseStamped, 'bench/ping', COMMAND_QOS)
    executor = make_executor(context, 'events')
    executor.add_node(bench)
    stop = threading.Event()
    thread = threading.Thread(target=spin_until_shutdown, args=(executor, context, stop),
                              kwargs={'period': 0.01}, daemon=True)
    thread.start()
    try:
        if not wait_until(lambda: target_pub.get_subscription_count() and ping_pub.get_subscription_count()
                          and bench.count_publishers(f'{NAMESPACE}/pose') and
                          bench.count_publishers(f'{NAMESPACE}/bench/pong'), 30):
            raise RuntimeError('the processes did not come up')
        time.sleep(0.5)
        return interleaved([(ping_pub, echo_waiter, bench), (target_pub, chain_waiter, bench)], poses, samples)
    finally:
        stop.set()
        thread.join(5.0)
        bench.destroy_node()
        rclpy.shutdown(context=context)
        stop_processes(processes)


def row(name: str, lat: np.ndarray, lost: int) -> str:
    us = lat * 1e6
    return (f'| {name} | {len(lat)} | {lost} | {np.percentile(us, 50):.0f} | {np.percentile(us, 99):.0f} '
            f'| {np.max(us):.0f} |')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--samples', type=int, default=2000)
    parser.add_argument('--executor', choices=('events', 'single', 'both'), default='both')
    parser.add_argument('--no-processes', action='store_true')
    parser.add_argument('--echo', action='store_true', help=argparse.SUPPRESS)
    args, ros_args = parser.parse_known_args()
    if args.echo:
        run_nodes([Echo], ['echo', *ros_args])
        return
    domain_id = 100 + os.getpid() % 100
    poses = targets(64)
    print(f'# chain latency: target_pose -> ik -> driver -> fk -> pose ({platform.processor() or platform.machine()}, '
          f'{os.cpu_count()} cores, Python {platform.python_version()}, {args.samples} samples each, '
          f'load average {os.getloadavg()[0]:.1f} at start)\n')
    print('| run | samples | lost | p50 [us] | p99 [us] | max [us] |')
    print('|---|---|---|---|---|---|')
    verdicts = []
    for kind in (('events', 'single') if args.executor == 'both' else (args.executor,)):
        (bare, bare_lost), (chain, chain_lost) = in_process(kind, args.samples, poses, domain_id)
        print(row(f'in-process {kind}: bare pub->sub (baseline)', bare, bare_lost))
        print(row(f'in-process {kind}: chain', chain, chain_lost))
        added = (np.percentile(chain, 99) - np.percentile(bare, 99)) * 1e3
        verdicts.append(f'in-process {kind}: chain adds {added:.3f} ms p99 over bare pub->sub '
                        f'(target <= 1 ms: {"met" if added <= 1.0 else "MISSED"})')
        sys.stdout.flush()
    if not args.no_processes:
        (echo, echo_lost), (chain, chain_lost) = across_processes(args.samples, poses, domain_id + 1)
        print(row('processes: echo round trip, 2 hops (baseline)', echo, echo_lost))
        print(row('processes: chain, 4 hops', chain, chain_lost))
        verdicts.append(f'processes: chain adds {(np.percentile(chain, 99) - np.percentile(echo, 99)) * 1e3:.3f} '
                        'ms p99 over the 2-hop echo round trip')
    print()
    for line in verdicts:
        print(line)


if __name__ == '__main__':
    main()
