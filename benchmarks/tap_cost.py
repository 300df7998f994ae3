"""What an active recording tap costs the publishing process, per 500 Hz stream.

One process publishes a JointState at 500 Hz (as the driver's ``actuators/state``), another
subscribes to it (as the IK node would). The publisher's CPU is measured in alternating phases:
no recorder (its tap idle), then a "sink" that only subscribes to the publisher's
``~/recording_tap`` (the tap active, as while a recorder runs; the sink does nothing with the
bundles). The same-run baseline is a plain publisher (no tap), whose CPU must not change with
the sink. Each variant is a flush period of the tap and an encoder: ``rrps_runtime.cdr``'s (written
with ``struct``, as shipped) or rosbags' serializer (the pinned library; the JointState copied into
its class from rclpy's slots). The recorder's CPU budget: this is the part of a recording that the
stack's own processes pay.

    python benchmarks/tap_cost.py [--seconds 8] [--cycles 3] [--flush-periods 0.1 0.25]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 80))

from rrps_testing.processes import cpu_seconds  # noqa: E402

RATE = 500.0
TOPIC = 'tap_cost/state'


def rosbags_joint_state_encoder():
    """A JointState's CDR by rosbags' serializer (the library the hand-written encoder is measured
    against): the message copied into rosbags' class from rclpy's slots."""
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    JointState, Header, Time = (store.types[t] for t in (
        'sensor_msgs/msg/JointState', 'std_msgs/msg/Header', 'builtin_interfaces/msg/Time'))

    def encode(msg) -> bytes:
        header, stamp = msg._header, msg._header._stamp
        return store.serialize_cdr(JointState(
            header=Header(stamp=Time(sec=stamp._sec, nanosec=stamp._nanosec), frame_id=header._frame_id),
            name=list(msg._name), position=np.asarray(msg._position, dtype=np.float64),
            velocity=np.asarray(msg._velocity, dtype=np.float64),
            effort=np.asarray(msg._effort, dtype=np.float64)), 'sensor_msgs/msg/JointState').tobytes()
    return encode


def publisher(flush_period: float, encoder: str) -> None:
    """The 500 Hz publisher; a tapped one for flush_period > 0 (JointState encoded by ``encoder``:
    'struct' or 'rosbags'), else a plain one."""
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from rrps_runtime import cdr
    from rrps_runtime.messages import joint_state_msg
    from rrps_runtime.process import run_nodes
    from rrps_runtime.qos import STATE_QOS
    from rrps_runtime.recording_tap import RecordingTap

    if encoder == 'rosbags':
        cdr._ENCODERS['sensor_msgs/msg/JointState'] = rosbags_joint_state_encoder()

    class Publisher(Node):
        def __init__(self, *, context):
            super().__init__('tap_cost_publisher', context=context)
            if flush_period > 0.0:
                self._tap = RecordingTap(self, flush_period=flush_period)
                self._pub = self._tap.create_publisher(JointState, TOPIC, STATE_QOS)
            else:
                self._pub = self.create_publisher(JointState, TOPIC, STATE_QOS)
            self._names = [f'leg_{i}' for i in range(1, 7)]
            self._rng = np.random.default_rng(0)
            self.create_timer(1.0 / RATE, self._tick)

        def _tick(self) -> None:
            x = self._rng.random(6)
            self._pub.publish(joint_state_msg(self.get_clock().now().to_msg(), x, x, x, names=self._names))

    run_nodes([Publisher], ['tap_cost_publisher'])


def subscriber(kind: str) -> None:
    """'reader': the stream's subscriber; 'sink': the publisher's recording tap's."""
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import UInt8MultiArray

    from rrps_interfaces.recording import RECORDING_TAP
    from rrps_runtime.process import run_nodes
    from rrps_runtime.qos import STATE_QOS
    from rrps_runtime.recording_tap import TAP_QOS

    class Subscriber(Node):
        def __init__(self, *, context):
            super().__init__(f'tap_cost_{kind}', context=context)
            if kind == 'reader':
                self.create_subscription(JointState, TOPIC, lambda msg: None, STATE_QOS)
            else:
                self.create_subscription(UInt8MultiArray, f'/tap_cost_publisher/{RECORDING_TAP}',
                                         lambda data: None, TAP_QOS, raw=True)

    run_nodes([Subscriber], [f'tap_cost_{kind}'])


def _child(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, __file__, *args])


def measure(flush_period: float, encoder: str, seconds: float, cycles: int) -> tuple[list[float], list[float]]:
    """The publisher's CPU [% of a core] in the idle phases and the sink phases (alternating,
    starting and ending idle)."""
    from rrps_runtime.supervision import stop_child

    pub, reader = _child('publisher', str(flush_period), encoder), _child('subscriber', 'reader')
    idle, sink = [], []
    try:
        time.sleep(5.0)  # start-up and discovery
        for phase in ['idle', 'sink'] * cycles + ['idle']:
            extra = _child('subscriber', 'sink') if phase == 'sink' else None
            time.sleep(3.0)  # the sink matched: the tap is active
            c0, t0 = cpu_seconds([pub.pid]), time.monotonic()
            time.sleep(seconds)
            cpu = 100.0 * (cpu_seconds([pub.pid]) - c0) / (time.monotonic() - t0)
            (sink if phase == 'sink' else idle).append(cpu)
            if extra is not None:
                stop_child(extra)
    finally:
        stop_child(pub)
        stop_child(reader)
    return idle, sink


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=8.0, help='length of each phase [s]')
    parser.add_argument('--cycles', type=int, default=3, help='idle/sink cycles per variant')
    parser.add_argument('--flush-periods', type=float, nargs='+', default=[0.1],
                        help="the taps' flush periods to measure [s]")
    args = parser.parse_args()
    print(f'Publisher CPU of one {RATE:g} Hz JointState stream, {args.seconds:g} s phases, '
          f'{os.cpu_count()} CPUs (shared)')
    print(f'{"publisher":<40}{"idle [% core]":>15}{"sink [% core]":>15}{"added":>14}{"per message [us]":>18}')
    variants = [(0.0, 'struct'), *((f, 'struct') for f in args.flush_periods), (args.flush_periods[0], 'rosbags')]
    for flush_period, encoder in variants:
        idle, sink = measure(flush_period, encoder, args.seconds, args.cycles)
        # each sink phase against the idle phases on either side of it
        added = np.array([s - 0.5 * (idle[i] + idle[i + 1]) for i, s in enumerate(sink)])
        name = ('plain (baseline)' if flush_period == 0.0
                else f'tapped, flush {flush_period:g} s, {"rrps_runtime.cdr" if encoder == "struct" else "rosbags"}')
        print(f'{name:<40}{np.mean(idle):>15.2f}{np.mean(sink):>15.2f}'
              f'{added.mean():>+9.2f} ± {added.std(ddof=1) / np.sqrt(len(added)) if len(added) > 1 else 0.0:.2f}'
              f'{1e4 * added.mean() / RATE:>18.1f}')
    return 0


if __name__ == '__main__':
    if len(sys.argv) > 1 and sys.argv[1] == 'publisher':
        publisher(float(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) > 1 and sys.argv[1] == 'subscriber':
        subscriber(sys.argv[2])
    else:
        sys.exit(main())
