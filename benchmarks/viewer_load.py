"""Viewer load: the 500 Hz control loop and the viewers' update rate with N web clients.

Starts the demo stack (``python -m rrps_bringup.demo``: driver at 500 Hz, IK, FK, master, teleop,
climb, viewer) as its own process, makes the robot move (the master runs its circle trajectory
and this script holds the deadman), then measures twice in the same run:

* baseline: no browser connected;
* one viewer: one websocket client speaking viser's protocol (what a browser receives:
  zstd-compressed msgpack batches), counting the batches that update the robot's pose;
* loaded: ``--clients`` such clients; with ``--slow-client`` the last one reads only one batch
  every 0.5 s (a browser on a starved link): the others must not slow down for it.

The viewer's CPU per client is printed for the first client and for each further one: viser's
windows are encoded once for all clients (rrps_viewer._broadcast), so what a further
client adds is its websocket send.

The control loop's period is taken from the driver's ``actuators/state`` header stamps (its
timer), received by a separate process so that measuring does not load the stack.

    python benchmarks/viewer_load.py [--clients 10] [--seconds 10]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import secrets
import socket
import subprocess
import sys
import threading
import time

import numpy as np

from rrps_testing.processes import cpu_seconds, interrupt  # noqa: E402

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 80))

POSE_NODE = '/robot/ring_b'
SLOW_CLIENT_DELAY = 0.5  # [s] between the slow client's reads


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _decode(data: bytes) -> list[dict]:
    """The messages of one viser batch (see viser.infra._infra's wire format)."""
    import msgspec
    import zstandard
    size = int.from_bytes(data[0:8], 'little')
    compressed = int.from_bytes(data[8:16], 'little')
    inner = zstandard.ZstdDecompressor().decompress(data[16:16 + compressed], max_output_size=size)
    return msgspec.msgpack.decode(inner)['messages']


def _camera_message() -> bytes:
    """The first message a browser sends: its camera. viser counts a client as connected (and
    calls the viewer's on_client_connect) only once it arrived."""
    import msgspec
    from viser._messages import ViewerCameraMessage
    camera = ViewerCameraMessage(wxyz=(1.0, 0.0, 0.0, 0.0), position=(1.0, 1.0, 1.0), fov=1.0,
                                 near=0.01, far=100.0, image_height=720, image_width=1280,
                                 look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0))
    return msgspec.msgpack.encode(camera.as_serializable_dict())


class Client:
    """One websocket viewer: announces its camera as a browser does, then counts every batch and
    those that move the robot."""

    def __init__(self, url: str, delay: float = 0.0):
        self.url = url
        self.delay = delay  # [s] between two reads: a slow client
        self.batches: list[float] = []
        self.pose_updates: list[float] = []
        self.bytes = 0
        self.error: str | None = None

    async def run(self, stop: asyncio.Event) -> None:
        import viser
        import websockets
        try:
            async with websockets.connect(self.url, subprotocols=[f'viser-v{viser.__version__}'],
                                          max_size=None) as ws:
                await ws.send(_camera_message())
                while not stop.is_set():
                    try:
                        data = await asyncio.wait_for(ws.recv(), timeout=0.5)
                    except asyncio.TimeoutError:
                        continue
                    if self.delay:
                        await asyncio.sleep(self.delay)
                    now = time.monotonic()
                    self.batches.append(now)
                    self.bytes += len(data)
                    if any(m.get('name') == POSE_NODE for m in _decode(data)):
                        self.pose_updates.append(now)
        except Exception as exc:  # reported in the table
            self.error = repr(exc)

    def rate(self, t0: float, t1: float, which: str = 'pose_updates') -> float:
        times = np.asarray(getattr(self, which))
        return float(np.count_nonzero((times >= t0) & (times < t1)) / (t1 - t0))


def _clients_thread(url: str, n: int, stop_flag: threading.Event,
                    slow: bool = False) -> tuple[list[Client], threading.Thread]:
    clients = [Client(url, SLOW_CLIENT_DELAY if slow and i == n - 1 else 0.0) for i in range(n)]

    def main() -> None:
        async def go() -> None:
            stop = asyncio.Event()
            tasks = [asyncio.create_task(c.run(stop)) for c in clients]
            while not stop_flag.is_set():
                await asyncio.sleep(0.1)
            stop.set()
            await asyncio.gather(*tasks)
        asyncio.run(go())

    thread = threading.Thread(target=main, daemon=True)
    thread.start()
    return clients, thread


def _phase_with_clients(url: str, n: int, slow: bool, seconds: float, pid: int):
    """Connect ``n`` clients, let them receive the scene, then measure for ``seconds``:
    (clients, t_start, t_end, CPU seconds of ``pid`` at start, at end)."""
    stop_flag = threading.Event()
    clients, thread = _clients_thread(url, n, stop_flag, slow=slow)
    time.sleep(3.0)  # connect, receive the scene
    t_start, cpu_start = time.monotonic(), cpu_seconds([pid])
    time.sleep(seconds)
    t_end, cpu_end = time.monotonic(), cpu_seconds([pid])
    stop_flag.set()
    thread.join(timeout=10.0)
    return clients, t_start, t_end, cpu_start, cpu_end


def _periods(stamps: list[tuple[float, float]], t0: float, t1: float) -> np.ndarray:
    s = np.array([stamp for recv, stamp in stamps if t0 <= recv < t1])
    return np.diff(s) if len(s) > 2 else np.array([np.nan])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--clients', type=int, default=10)
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--busy-core', action='store_true',
                        help='keep one core busy (a spinning process) through every phase')
    parser.add_argument('--slow-client', action='store_true',
                        help=f'the last client reads one batch every {SLOW_CLIENT_DELAY} s')
    args = parser.parse_args()
    from rrps_runtime.supervision import start_child
    busy = start_child([sys.executable, '-c', 'while True: pass']) if args.busy_core else None

    import rclpy
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool

    from rrps_runtime.messages import stamp_to_seconds
    from rrps_runtime.process import make_executor, spin_until_shutdown
    from rrps_runtime.qos import COMMAND_QOS, STATE_QOS

    port, token = _free_port(), secrets.token_urlsafe(12)
    demo = subprocess.Popen([sys.executable, '-m', 'rrps_bringup.demo', '--port', str(port),
                             '--token', token], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    context = rclpy.Context()
    rclpy.init(context=context)
    stop = threading.Event()
    node = Node('viewer_load', context=context, namespace='/rrps')
    stamps: list[tuple[float, float]] = []
    lock = threading.Lock()

    def on_state(msg) -> None:
        with lock:
            stamps.append((time.monotonic(), stamp_to_seconds(msg.header.stamp)))

    node.create_subscription(JointState, 'actuators/state', on_state, STATE_QOS)
    enable = node.create_publisher(Bool, 'teleop/enable', COMMAND_QOS)
    node.create_timer(0.05, lambda: enable.publish(Bool(data=True)))  # hold the deadman
    executor = make_executor(context, 'events')
    executor.add_node(node)
    spinner = threading.Thread(target=spin_until_shutdown, args=(executor, context, stop),
                               daemon=True)
    spinner.start()
    try:
        deadline = time.monotonic() + 60.0
        for line in demo.stdout:
            if 'operator token' in line or time.monotonic() > deadline:
                break
        threading.Thread(target=lambda: [None for _ in demo.stdout], daemon=True).start()
        client = node.create_client(SetParameters, 'master_node/set_parameters')
        if not client.wait_for_service(timeout_sec=20.0):
            print('error: the demo did not come up', file=sys.stderr)
            return 1
        future = client.call_async(SetParameters.Request(parameters=[Parameter(
            name='trajectory', value=ParameterValue(type=ParameterType.PARAMETER_STRING,
                                                    string_value='circle'))]))
        while not future.done():
            time.sleep(0.05)

        def moving() -> bool:  # the driver publishes at its full rate only while the robot moves
            now = time.monotonic()
            with lock:
                return sum(1 for recv, _ in stamps[-500:] if recv > now - 1.0) > 250
        deadline = time.monotonic() + 60.0
        while not moving():
            if time.monotonic() > deadline:
                print('error: the robot did not start moving (teleop engaged by the deadman, the '
                      'master on its circle)', file=sys.stderr)
                return 1
            time.sleep(0.2)

        t0, cpu0 = time.monotonic(), cpu_seconds([demo.pid])
        time.sleep(args.seconds)
        t1, cpu1 = time.monotonic(), cpu_seconds([demo.pid])
        url = f'ws://127.0.0.1:{port}'
        one, ta, tb, cpua, cpub = _phase_with_clients(url, 1, False, args.seconds, demo.pid)
        clients, t2, t3, cpu2, cpu3 = _phase_with_clients(url, args.clients, args.slow_client,
                                                          args.seconds, demo.pid)
        with lock:
            recorded = list(stamps)
    finally:
        stop.set()
        spinner.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        if busy is not None:
            busy.kill()
            busy.wait()
        interrupt(demo, timeout=15.0)

    base, loaded = _periods(recorded, t0, t1), _periods(recorded, t2, t3)
    print(f'\nViewer load: demo stack (driver 500 Hz) with {args.clients} websocket viewers, '
          f'{args.seconds:g} s per phase, {os.cpu_count()} CPUs'
          f'{", the other core kept busy" if args.busy_core else ""}'
          f'{", the last client slow" if args.slow_client else ""}, load average {os.getloadavg()[0]:.1f}')
    print(f'{"phase":<22}{"driver period p50 [ms]":>24}{"p99 [ms]":>10}{"max [ms]":>10}'
          f'{"state rate [Hz]":>17}')
    for name, p in (('baseline: 0 viewers', base), (f'loaded: {args.clients} viewers', loaded)):
        print(f'{name:<22}{1e3 * np.median(p):>24.3f}{1e3 * np.percentile(p, 99):>10.3f}'
              f'{1e3 * np.max(p):>10.3f}{len(p) / max(np.sum(p), 1e-9):>17.1f}')
    print(f'\n{"viewer":<8}{"pose updates [Hz]":>19}{"batches [Hz]":>14}{"kB/s":>8}  error')
    rates = []
    for i, c in enumerate(clients):
        rate = c.rate(t2, t3)
        if not c.delay:
            rates.append(rate)
        print(f'{i:<8}{rate:>19.1f}{c.rate(t2, t3, "batches"):>14.1f}'
              f'{c.bytes / 1e3 / (t3 - t2 + 3.0):>8.1f}  {"(slow) " if c.delay else ""}{c.error or ""}')
    print(f'alone   {one[0].rate(ta, tb):>19.1f}{one[0].rate(ta, tb, "batches"):>14.1f}'
          f'{one[0].bytes / 1e3 / (tb - ta + 3.0):>8.1f}  (the one-viewer phase) {one[0].error or ""}')
    base_cpu = 100.0 * (cpu1 - cpu0) / (t1 - t0)
    one_cpu = 100.0 * (cpub - cpua) / (tb - ta)
    loaded_cpu = 100.0 * (cpu3 - cpu2) / (t3 - t2)
    print(f'\noperator process (master, teleop, viewer) CPU: {base_cpu:.1f} % without viewers, '
          f'{one_cpu:.1f} % with 1, {loaded_cpu:.1f} % with {args.clients}: the first viewer adds '
          f'{one_cpu - base_cpu:.2f} % of a core, each further one '
          f'{(loaded_cpu - one_cpu) / max(args.clients - 1, 1):.2f} %')
    ok = bool(rates) and min(rates) >= 30.0
    which = 'regular viewer' if args.slow_client else 'viewer'
    print(f'slowest {which} {min(rates):.1f} Hz (target >= 30 Hz): {"MET" if ok else "MISSED"}; '
          f'driver period p99 {1e3 * np.percentile(loaded, 99):.2f} ms loaded vs '
          f'{1e3 * np.percentile(base, 99):.2f} ms baseline (nominal 2.000 ms)')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
