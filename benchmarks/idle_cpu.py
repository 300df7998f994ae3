"""CPU of the demo stack at rest: nothing moves and no browser is connected.

Two measurements in the same run, each over ``--seconds`` after the stack settled:

* per node: every node of the demo in a process of its own (``rrps-compose NODE``), so that
  each one's CPU is its own (plus its process' share of the DDS and executor overhead);
* the demo as it runs (``rrps-demo``: driver, robot nodes, observers and operator station in
  four processes), the number the target is about: <= 25 % of one core in total.

CPU comes from /proc (user + system time of each process and its threads).

    python benchmarks/idle_cpu.py [--seconds 20]
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(100 + os.getpid() % 50))

from rrps_testing.processes import cpu_seconds  # noqa: E402

NAMESPACE = '/rrps'
NODES = ('driver_node', 'ik_node', 'fk_node', 'climb_node', 'master_node', 'teleop_node',
         'viewer_node', 'recorder_node', 'markers_node')
#: The demo's processes, told apart by a node each one runs.
PROCESSES = {'driver_node': 'driver process',
             'climb_node': 'robot process (ik, fk, climb)',
             'recorder_node': 'observer process (flight recorder, markers)',
             'rrps_bringup.demo': 'operator process (master, teleop, viewer)'}
TARGET = 25.0  # % of one core, the whole demo at rest


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _descendants(pid: int) -> list[int]:
    children = {}
    for entry in os.listdir('/proc'):
        if entry.isdigit():
            try:
                ppid = int(Path(f'/proc/{entry}/stat').read_text().rsplit(')', 1)[1].split()[1])
            except (OSError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += children.get(p, [])
    return out


def _measure(pids: dict[str, int], settle: float, seconds: float) -> dict[str, float]:
    time.sleep(settle)
    before = {name: cpu_seconds([pid]) for name, pid in pids.items()}
    t0 = time.monotonic()
    time.sleep(seconds)
    elapsed = time.monotonic() - t0
    return {name: 100.0 * (cpu_seconds([pid]) - before[name]) / elapsed
            for name, pid in pids.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=20.0)
    parser.add_argument('--settle', type=float, default=15.0, help='start-up time before measuring')
    args = parser.parse_args()
    from rrps_runtime.supervision import start_child, stop_children

    common = ['--ros-args', '-r', f'__ns:={NAMESPACE}', '-p', 'robot:=pole_climber']
    per_node = {}
    for name in NODES:
        extra = ['-p', 'auto_activate:=true'] if name == 'driver_node' else []
        if name == 'viewer_node':
            extra = ['-p', f'port:={_free_port()}', '-p', 'token:=idle-benchmark-token']
        if name == 'recorder_node':
            extra = ['-p', f'output_dir:={tempfile.mkdtemp(prefix="rrps-idle-")}']
        if name == 'master_node':
            common_master = ['--ros-args', '-r', f'__ns:={NAMESPACE}']
            per_node[name] = start_child([sys.executable, '-m', 'rrps_bringup.compose', name,
                                          *common_master])
            continue
        per_node[name] = start_child([sys.executable, '-m', 'rrps_bringup.compose', name, *common,
                                      *extra])
    try:
        nodes = _measure({n: p.pid for n, p in per_node.items()}, args.settle, args.seconds)
    finally:
        stop_children(list(per_node.values()))

    demo = start_child([sys.executable, '-m', 'rrps_bringup.demo', '--port', str(_free_port())],
                       stdout=open(os.devnull, 'w'), stderr=open(os.devnull, 'w'))
    try:
        pids: dict[str, int] = {}
        deadline = time.monotonic() + 180.0
        while len(pids) < len(PROCESSES) and time.monotonic() < deadline:  # the demo's children
            time.sleep(1.0)
            for pid in _descendants(demo.pid):
                try:
                    cmd = Path(f'/proc/{pid}/cmdline').read_bytes().replace(b'\0', b' ').decode()
                except OSError:
                    continue
                label = next((label for key, label in PROCESSES.items() if key in cmd), None)
                if label:
                    pids[label] = pid
        if len(pids) < len(PROCESSES):
            raise RuntimeError(f'the demo did not start its processes: {sorted(pids)}')
        processes = _measure(pids, args.settle, args.seconds)
    finally:
        stop_children([demo])

    print(f'\nIdle CPU of the stack (nothing moves, no browser), {args.seconds:g} s, '
          f'{os.cpu_count()} CPUs [% of one core]')
    print(f'{"node (a process each)":<44}{"CPU":>8}')
    for name, cpu in nodes.items():
        print(f'{name:<44}{cpu:>7.1f}%')
    print(f'{"sum":<44}{sum(nodes.values()):>7.1f}%')
    print(f'\n{"demo process":<44}{"CPU":>8}')
    for name, cpu in processes.items():
        print(f'{name:<44}{cpu:>7.1f}%')
    total = sum(processes.values())
    ok = total <= TARGET
    print(f'{"demo total":<44}{total:>7.1f}%   target <= {TARGET:.0f} %: {"MET" if ok else "MISSED"}')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
