"""A node's recording tap: its high-rate publications, batched for a recorder.

Receiving every message of the stack again, in a separate process, costs a recorder more than
the recording budget before it writes a byte (see :mod:`rrps_kinematics.recording_bundle`).
A node therefore creates its high-rate publishers through its :class:`RecordingTap`::

    self._tap = RecordingTap(self)
    self._state_pub = self._tap.create_publisher(JointState, ACTUATORS_STATE, STATE_QOS)
    self._state_pub.publish(msg)          # as a plain publisher

While nobody subscribes to the node's ``~/recording_tap`` (no recorder runs), ``publish`` is
the plain publisher's. While a recorder subscribes, ``publish`` serialises the message once,
publishes those CDR bytes (what rclpy would have sent) and keeps them with their publish time;
every ``FLUSH_PERIOD`` the kept messages go out as one bundle (``std_msgs/UInt8MultiArray``)
on ``~/recording_tap``, reliable. The subscribers of the topic itself see no difference.
"""

from __future__ import annotations

import threading
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from std_msgs.msg import UInt8MultiArray

from ..interfaces import RECORDING_TAP
from ..recording_bundle import BundleWriter

__all__ = ['RecordingTap', 'TappedPublisher', 'TAP_QOS', 'FLUSH_PERIOD', 'message_type_name']

#: Bundles are sent this often [s] (and when the kept messages pass MAX_PENDING_BYTES).
FLUSH_PERIOD = 0.1
#: A bundle is sent at once past this many bytes of kept messages.
MAX_PENDING_BYTES = 1 << 20
#: An idle tap still sends its (empty) bundle this often [s], so a recorder learns its topics.
IDLE_PERIOD = 1.0
#: Reliable, a few seconds of bundles deep: a recorder that falls behind loses none of them.
TAP_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)


def message_type_name(msg_type) -> str:
    """'sensor_msgs/msg/JointState' for rclpy's JointState class."""
    return f'{msg_type.__module__.split(".")[0]}/msg/{msg_type.__name__}'


class TappedPublisher:
    """A publisher whose messages also go to the node's recording tap while a recorder listens."""

    __slots__ = ('publisher', '_tap', '_index')

    def __init__(self, tap: RecordingTap, publisher, index: int):
        self.publisher = publisher
        self._tap = tap
        self._index = index

    def publish(self, msg) -> None:
        """Publish ``msg``; while tapped, as its CDR bytes, kept for the next bundle."""
        if not self._tap.active:
            self.publisher.publish(msg)
            return
        data = serialize_message(msg)
        self.publisher.publish(data)
        self._tap.keep(self._index, data)


class RecordingTap:
    """One node's bundle of tapped publications; see the module docstring."""

    def __init__(self, node: Node, *, flush_period: float = FLUSH_PERIOD,
                 max_pending_bytes: int = MAX_PENDING_BYTES):
        self._writer = BundleWriter(node.get_fully_qualified_name())
        self._lock = threading.Lock()
        self._max_pending_bytes = max_pending_bytes
        self._bundle_pub = node.create_publisher(UInt8MultiArray, f'~/{RECORDING_TAP}', TAP_QOS)
        self._node = node
        self._last_sent = -float('inf')
        #: True while a recorder subscribes to the bundles (checked every flush period).
        self.active = False
        self.bundles_sent = 0
        node.create_timer(flush_period, self.flush)

    def create_publisher(self, msg_type, topic: str, qos) -> TappedPublisher:
        """A tapped publisher of ``topic`` (the node's ``create_publisher`` arguments)."""
        publisher = self._node.create_publisher(msg_type, topic, qos)
        with self._lock:
            index = self._writer.declare(publisher.topic_name, message_type_name(msg_type))
        return TappedPublisher(self, publisher, index)

    def keep(self, index: int, data: bytes) -> None:
        """Keep a published message's CDR bytes for the next bundle."""
        with self._lock:
            self._writer.add(index, time.time_ns(), data)
            full = self._writer.pending_bytes >= self._max_pending_bytes
        if full:
            self.flush()

    def flush(self) -> None:
        """Send the kept messages as one bundle (an empty one at most every IDLE_PERIOD)."""
        active = self._bundle_pub.get_subscription_count() > 0
        now = time.monotonic()
        with self._lock:
            self.active = active
            if not active:
                self._writer.clear()
                return
            if self._writer.pending_messages == 0 and now - self._last_sent < IDLE_PERIOD:
                return
            data = self._writer.take(time.time_ns())
        self._last_sent = now
        self._bundle_pub.publish(data)
        self.bundles_sent += 1
