"""Load harness: run the test suite (or any command) on a busy machine, as CI machines are.

    python -m rrps_testing.load [--busy N] [--flood-rate HZ] [--browser URL] -- COMMAND ...
    ./rrps test --load [PYTEST ARGS]          # the same load around a pytest run

While COMMAND runs it keeps ``--busy`` cores spinning, floods DDS on loopback (``--flood-rate`` Hz, a domain of its own)
and optionally shows ``--browser`` URL in a software-rendered headless Chromium; it returns COMMAND's exit status
and stops every load process, also when interrupted. A test that passes only on an idle machine fails under it.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

#: Domain id of the flood: away from the tests' ids (1..100, conftest.py).
FLOOD_DOMAIN_ID = 201

_BUSY = 'while True:\n    pass\n'

_FLOOD_PUBLISHER = r'''
import sys, time
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
rate = float(sys.argv[1])
context = rclpy.Context()
rclpy.init(context=context)
node = rclpy.create_node('load_flood_publisher', context=context)
qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
joints = node.create_publisher(JointState, 'load/joints', qos)
poses = node.create_publisher(PoseStamped, 'load/pose', qos)
msg = JointState(name=[f'joint_{i}' for i in range(32)], position=[0.0] * 32,
                 velocity=[0.0] * 32, effort=[0.0] * 32)
period = 1.0 / rate
next_t = time.monotonic()
try:
    while context.ok():
        msg.header.stamp = node.get_clock().now().to_msg()
        joints.publish(msg)
        pose = PoseStamped()
        pose.header.stamp = msg.header.stamp
        poses.publish(pose)
        next_t += period
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            next_t = time.monotonic()
except KeyboardInterrupt:
    pass
'''

_FLOOD_SUBSCRIBER = r'''
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
context = rclpy.Context()
rclpy.init(context=context)
node = rclpy.create_node('load_flood_subscriber', context=context)
qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
count = [0]
node.create_subscription(JointState, 'load/joints', lambda m: count.__setitem__(0, count[0] + 1), qos)
node.create_subscription(PoseStamped, 'load/pose', lambda m: count.__setitem__(0, count[0] + 1), qos)
executor = SingleThreadedExecutor(context=context)
executor.add_node(node)
try:
    while context.ok():
        executor.spin_once(timeout_sec=0.1)
except KeyboardInterrupt:
    pass
'''

_BROWSER_FLAGS = ('--headless', '--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader',
                  '--disable-quic', '--no-first-run', '--disable-background-networking',
                  '--disable-component-update', '--disable-sync', '--window-size=860,600',
                  '--remote-debugging-port=0')


class Load:
    """The load processes; a context manager that starts them and always stops them."""

    def __init__(self, *, busy: int = 1, flood_rate: float = 2000.0, browser_url: str | None = None,
                 quiet: bool = False):
        if busy < 0 or flood_rate < 0.0:
            raise ValueError('busy and flood_rate must be >= 0')
        self.busy = busy
        self.flood_rate = flood_rate
        self.browser_url = browser_url
        self.quiet = quiet
        self.processes: list[subprocess.Popen] = []
        self._profile: str | None = None

    def _say(self, text: str) -> None:
        if not self.quiet:
            print(f'load: {text}', file=sys.stderr, flush=True)

    def _spawn(self, args: list[str], env: dict | None = None) -> subprocess.Popen:
        # start_child: a load process dies with the process that started it, also when that one
        # is killed (a benchmark stopped by a timeout left its busy loop, flood and browser).
        from rrps_runtime.supervision import start_child
        process = start_child(args, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)
        self.processes.append(process)
        return process

    def start(self) -> 'Load':
        for _ in range(self.busy):
            self._spawn([sys.executable, '-c', _BUSY])
        if self.busy:
            self._say(f'{self.busy} process(es) keeping a core busy')
        if self.flood_rate > 0.0:
            env = {**os.environ, 'ROS_DOMAIN_ID': str(FLOOD_DOMAIN_ID),
                   'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
            self._spawn([sys.executable, '-c', _FLOOD_SUBSCRIBER], env)
            self._spawn([sys.executable, '-c', _FLOOD_PUBLISHER, str(self.flood_rate)], env)
            self._say(f'a ROS process flooding domain {FLOOD_DOMAIN_ID} at '
                      f'{self.flood_rate:g} Hz x 2 topics, taken by another process')
        if self.browser_url:
            chromium = os.environ.get('CHROMIUM') or shutil.which('chromium')
            if chromium is None:
                raise FileNotFoundError('--browser needs chromium (apt-get install chromium)')
            self._profile = tempfile.mkdtemp(prefix='rrps-load-chromium-')
            self._spawn([chromium, *_BROWSER_FLAGS, f'--user-data-dir={self._profile}',
                         self.browser_url])
            self._say(f'software-rendered chromium showing {self.browser_url}')
        return self

    def stop(self) -> None:
        for process in self.processes:
            if process.poll() is None:
                try:
                    os.killpg(process.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + 5.0
        for process in self.processes:
            try:
                process.wait(max(deadline - time.monotonic(), 0.1))
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
        self.processes.clear()
        if self._profile is not None:
            shutil.rmtree(self._profile, ignore_errors=True)
            self._profile = None

    def __enter__(self) -> 'Load':
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *exc_info) -> None:
        self.stop()


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='python -m rrps_testing.load', description='Run COMMAND while other processes load the machine '
                                          '(a busy core, a DDS flood, optionally a browser).')
    p.add_argument('--busy', type=int, default=1, help='processes spinning a core each (default 1)')
    p.add_argument('--flood-rate', type=float, default=2000.0,
                   help='DDS messages per second per topic of the flood (0: none; default 2000)')
    p.add_argument('--browser', metavar='URL', default=None,
                   help='also show URL in a software-rendered headless Chromium')
    p.add_argument('--browser-delay', type=float, default=0.0, metavar='S',
                   help='start the browser S seconds after COMMAND (a server that must come up first)')
    p.add_argument('command', nargs=argparse.REMAINDER, help='-- COMMAND [ARGS...]')
    return p


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    command = args.command[1:] if args.command[:1] == ['--'] else args.command
    if not command:
        print('error: give a command after --', file=sys.stderr)
        return 2
    url = args.browser
    load = Load(busy=args.busy, flood_rate=args.flood_rate,
                browser_url=None if args.browser_delay > 0 else url)
    browser = None
    with load:
        process = subprocess.Popen(command)
        try:
            if url and args.browser_delay > 0:
                time.sleep(args.browser_delay)
                browser = Load(busy=0, flood_rate=0.0, browser_url=url).start()
            return process.wait()
        except KeyboardInterrupt:
            process.send_signal(signal.SIGINT)
            return process.wait()
        finally:
            if browser is not None:
                browser.stop()


if __name__ == '__main__':
    sys.exit(main())
