"""Executor lag of the demo stack under load: how late commands reach the robot's nodes.

Runs the demo's nodes in three compositions, one after the other in the same run and under the
same load, and climbs step after step (``climb/step_up``, ``climb/step_down``) for
``--seconds`` each:

* ``one operator+robot process`` (the first release): the driver in its own process, IK, FK,
  master, teleop, climb and viewer in one process and one executor;
* ``robot / operator split``: the driver; IK, FK and climb in one process; master, teleop and
  viewer in another; every process at the default priority;
* ``split + nice values``: the same split, with the driver and the robot's nodes at nice
  ``CONTROL_NICE`` and the operator station at ``OPERATOR_NICE`` (each in a scheduling group
  of its own);
* ``split + real-time control (demo)`` (now, ``rrps-demo``): the driver and the robot's nodes
  at SCHED_RR ``CONTROL_RT_PRIORITY``, the operator station at SCHED_RR ``OPERATOR_RT_PRIORITY``
  (:mod:`rrps_runtime.supervision`; raising priority needs root, as on a robot's computer).

The climb node streams ``target_pose`` at 50 Hz to the IK node of its own process; the IK node
and the driver report the ages of the commands they receive (receipt time minus stamp: the
executor's queue plus transport) on /diagnostics, read here. A command older than 0.1 s is
rejected as stale. CPU per process comes from /proc.

Load (``--load``, default on): one core kept busy, a second ROS process flooding the machine
with DDS messages, and a software-rendered headless Chromium showing the viewer
(``rrps_testing.load``).

    python benchmarks/executor_lag.py [--seconds 60] [--no-load]
"""

from __future__ import annotations

import argparse
import os
import secrets
import socket
import sys
import threading
import time

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))


from rrps_interfaces.status import source_node  # noqa: E402
from rrps_runtime.supervision import CONTROL_NICE, CONTROL_RT_PRIORITY, OPERATOR_NICE, OPERATOR_RT_PRIORITY
from rrps_testing.load import Load  # noqa: E402
from rrps_testing.processes import cpu_seconds  # noqa: E402

NAMESPACE = '/rrps'
ROBOT = ('ik_node', 'fk_node', 'climb_node')
OPERATOR = ('master_node', 'teleop_node', 'viewer_node')
NORMAL = {}
CONTROL_NICE_ONLY = {'nice': CONTROL_NICE}
CONTROL_RT = {'nice': CONTROL_NICE, 'realtime': CONTROL_RT_PRIORITY}
OPERATOR_NICE_ONLY = {'nice': OPERATOR_NICE}
OPERATOR_RT = {'nice': OPERATOR_NICE, 'realtime': OPERATOR_RT_PRIORITY}
DEMO = 'split + real-time control (demo)'
#: name: (the driver's scheduling, [(nodes of a process, its scheduling), ...]); a scheduling
#: is start_child's keyword arguments.
COMPOSITIONS = {
    'one operator+robot process': (NORMAL, [(ROBOT + OPERATOR, NORMAL)]),
    'robot / operator split': (NORMAL, [(ROBOT, NORMAL), (OPERATOR, NORMAL)]),
    'split + nice values': (CONTROL_NICE_ONLY, [(ROBOT, CONTROL_NICE_ONLY), (OPERATOR, OPERATOR_NICE_ONLY)]),
    DEMO: (CONTROL_RT, [(ROBOT, CONTROL_RT), (OPERATOR, OPERATOR_RT)]),
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


class Observer:
    """The benchmark's own node: climbs step after step, keeps the nodes' latest diagnostics."""

    def __init__(self, context):
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
        from rclpy.node import Node
        from std_srvs.srv import Trigger

        from rrps_runtime.qos import STATE_QOS

        self.node = Node('executor_lag', context=context, namespace=NAMESPACE)
        self.lock = threading.Lock()
        self.diagnostics: dict[str, dict[str, str]] = {}
        self.climb_state = ''
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      STATE_QOS)
        self.node.create_subscription(DiagnosticStatus, 'climb/status', self._on_climb, STATE_QOS)
        self.steps = {d: self.node.create_client(Trigger, f'climb/step_{d}') for d in ('up', 'down')}

    def _on_diagnostics(self, msg) -> None:
        with self.lock:
            for status in msg.status:
                self.diagnostics[source_node(status.name)] = {kv.key: kv.value for kv in status.values}

    def _on_climb(self, msg) -> None:
        with self.lock:
            self.climb_state = msg.message

    def values(self, node: str) -> dict[str, str]:
        with self.lock:
            return dict(self.diagnostics.get(node, {}))


def _climb_for(observer: Observer, seconds: float) -> int:
    """Step up and down until ``seconds`` pass; the number of completed steps."""
    from std_srvs.srv import Trigger

    done, direction = 0, 'up'
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        future = observer.steps[direction].call_async(Trigger.Request())
        t = time.monotonic()
        while not future.done() and time.monotonic() - t < 10.0:
            time.sleep(0.05)
        if not (future.done() and future.result().success):
            time.sleep(0.5)
            continue
        time.sleep(0.5)
        state = ''
        while time.monotonic() < deadline + 120.0:
            with observer.lock:
                state = observer.climb_state
            if state in ('idle', 'error'):
                break
            time.sleep(0.1)
        if state != 'idle':
            break
        done += 1
        direction = 'down' if direction == 'up' else 'up'
    return done


def run_composition(name: str, composition, *, seconds: float, load: bool) -> dict:
    import rclpy

    from rrps_runtime.process import make_executor, spin_until_shutdown
    from rrps_runtime.supervision import start_child, stop_children

    port, token = _free_port(), secrets.token_urlsafe(12)
    common = ['--ros-args', '-r', f'__ns:={NAMESPACE}', '-p', 'robot:=pole_climber']
    driver_scheduling, groups = composition
    children = [start_child([sys.executable, '-m', 'rrps_hardware.nodes.driver_node', *common,
                             '-p', 'auto_activate:=true'], **driver_scheduling)]
    labels = ['driver_node'] + ['+'.join(n.removesuffix('_node') for n in nodes) for nodes, _ in groups]
    for nodes, scheduling in groups:
        extra = ['-p', f'port:={port}', '-p', f'token:={token}'] if 'viewer_node' in nodes else []
        children.append(start_child([sys.executable, '-m', 'rrps_bringup.compose', *nodes,
                                     *common, *extra], **scheduling))
    context = rclpy.Context()
    rclpy.init(context=context)
    observer = Observer(context)
    executor = make_executor(context, 'events')
    executor.add_node(observer.node)
    stop = threading.Event()
    spinner = threading.Thread(target=spin_until_shutdown, args=(executor, context, stop),
                               daemon=True)
    spinner.start()
    loader = Load(busy=1, flood_rate=2000.0, browser_url=f'http://127.0.0.1:{port}', quiet=True) \
        if load else None
    try:
        if not observer.steps['up'].wait_for_service(timeout_sec=60.0):
            raise RuntimeError(f'{name}: the climb node did not come up')
        time.sleep(3.0)
        if loader is not None:
            loader.start()
            time.sleep(5.0)  # the browser loads the viewer
        cpu0 = {c.pid: cpu_seconds([c.pid]) for c in children}
        t0 = time.monotonic()
        steps = _climb_for(observer, seconds)
        elapsed = time.monotonic() - t0
        cpu = {label: 100.0 * (cpu_seconds([c.pid]) - cpu0[c.pid]) / elapsed
               for label, c in zip(labels, children)}
        time.sleep(1.0)  # the last diagnostics
        return {'steps': steps, 'ik': observer.values('ik_node'),
                'driver': observer.values('driver_node'), 'cpu': cpu,
                'alive': all(c.poll() is None for c in children)}
    finally:
        if loader is not None:
            loader.stop()
        stop.set()
        spinner.join(timeout=5.0)
        observer.node.destroy_node()
        rclpy.try_shutdown(context=context)
        stop_children(children)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=60.0, help='climbing time per composition')
    parser.add_argument('--no-load', dest='load', action='store_false',
                        help='no busy core, DDS flood or browser')
    parser.add_argument('--composition', action='append', choices=list(COMPOSITIONS),
                        help='run only this composition (repeatable; default: all, the demo last)')
    args = parser.parse_args()
    names = [n for n in COMPOSITIONS if n in (args.composition or COMPOSITIONS) or n == DEMO]
    results = {name: run_composition(name, COMPOSITIONS[name], seconds=args.seconds, load=args.load)
               for name in names}

    def v(values, key, fmt='{:.1f}'):
        """A reported value, '-' when the node did not report it (no command in the window)."""
        return fmt.format(float(values[key])) if values.get(key) else '-'

    print(f'\nExecutor lag while climbing ({args.seconds:g} s per composition, '
          f'{"loaded: busy core + DDS flood + software-rendered browser" if args.load else "no load"}'
          f', {os.cpu_count()} CPUs). Ages of the commands received, over the last 10 s [ms]:')
    print(f'{"composition":<34}{"steps":>6}{"IK target age p50":>19}{"p99":>8}{"max":>8}'
          f'{"stale":>7}{"driver cmd p99":>16}{"max":>8}{"stale":>7}')
    for name, r in results.items():
        ik, dr = r['ik'], r['driver']
        print(f'{name:<34}{r["steps"]:>6}{v(ik, "command_age_p50_ms"):>19}'
              f'{v(ik, "command_age_p99_ms"):>8}{v(ik, "command_age_max_ms"):>8}'
              f'{v(ik, "command_stale_total", "{:.0f}"):>7}{v(dr, "command_age_p99_ms"):>16}'
              f'{v(dr, "command_age_max_ms"):>8}{v(dr, "command_stale_total", "{:.0f}"):>7}')
    print('\nCPU per process while climbing [% of one core]:')
    for name, r in results.items():
        print(f'  {name}: ' + ', '.join(f'{k} {c:.0f} %' for k, c in r['cpu'].items()))
    now = results[DEMO]
    stale = int(float(now['ik'].get('command_stale_total', 'nan') or 0))
    ok = now['alive'] and now['steps'] > 0 and stale == 0
    print(f'\n{DEMO}: {stale} stale targets in the robot process: '
          f'{"MET" if ok else "MISSED"} (target: none)')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
