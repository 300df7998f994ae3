"""A node's recording tap: its high-rate publications, batched for a recorder (docs/recording.md, "Recording taps").

A node creates those publishers with :meth:`RecordingTap.create_publisher`. While a recorder subscribes to
``~/recording_tap``, each message is published as CDR bytes (:mod:`rrps_runtime.cdr` for JointState, PoseStamped and
WrenchStamped, rclpy's ``serialize_message`` for the others), those bytes are kept, and every ``FLUSH_PERIOD`` the
kept ones go out as one bundle (:mod:`rrps_runtime.recording_bundle`).
"""

from __future__ import annotations

import struct
import threading
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from std_msgs.msg import UInt8MultiArray

from rrps_interfaces.recording import RECORDING_TAP
from rrps_runtime.cdr import cdr_encoder
from rrps_runtime.recording_bundle import BundleWriter

__all__ = ['RecordingTap', 'TappedPublisher', 'TAP_QOS', 'FLUSH_PERIOD', 'message_type_name']

#: Bundles are sent this often [s] (and when MAX_PENDING_MESSAGES or MAX_PENDING_BYTES are kept).
FLUSH_PERIOD = 0.1
#: A bundle is sent at once past this many kept messages (4 s of a 500 Hz stream)...
MAX_PENDING_MESSAGES = 2000
#: ... or this many bytes of messages kept serialised.
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

    __slots__ = ('publisher', '_tap', '_index', '_encode')

    def __init__(self, tap: RecordingTap, publisher, index: int, encode):
        self.publisher = publisher
        self._tap = tap
        self._index = index
        self._encode = encode or serialize_message

    @property
    def tapped(self) -> bool:
        """True while a recorder listens: a published message is kept until the next bundle."""
        return self._tap.active

    def publish(self, msg) -> None:
        """Publish ``msg``; while tapped, publish its CDR bytes and keep them for the next bundle (one
        encoding: the recording holds the bytes that went out)."""
        if not self._tap.active:
            self.publisher.publish(msg)
            return
        try:
            data = self._encode(msg)
        except (AttributeError, TypeError, ValueError, struct.error) as exc:
            self.publisher.publish(msg)  # published all the same, left out of the recording
            self._tap.left_out(exc)
            return
        self.publisher.publish(data)
        self._tap.keep(self._index, data)


class RecordingTap:
    """One node's bundle of tapped publications; see the module docstring."""

    def __init__(self, node: Node, *, flush_period: float = FLUSH_PERIOD):
        self._writer = BundleWriter(node.get_fully_qualified_name())
        self._kept: list[tuple[int, int, bytes]] = []  # (topic, publish ns, CDR bytes)
        self._kept_bytes = 0
        self._lock = threading.Lock()        # the kept messages (publishers may run in threads)
        self._flush_lock = threading.Lock()  # the bundle writer
        self._bundle_pub = node.create_publisher(UInt8MultiArray, f'~/{RECORDING_TAP}', TAP_QOS)
        self._node = node
        self._last_sent = -float('inf')
        #: True while a recorder subscribes to the bundles (checked every flush period).
        self.active = False
        self.bundles_sent = 0
        #: Messages left out of the bundles because they could not be encoded.
        self.unencodable = 0
        node.create_timer(flush_period, self.flush)

    def create_publisher(self, msg_type, topic: str, qos) -> TappedPublisher:
        """A tapped publisher of ``topic`` (the node's ``create_publisher`` arguments)."""
        publisher = self._node.create_publisher(msg_type, topic, qos)
        type_name = message_type_name(msg_type)
        with self._flush_lock:
            index = self._writer.declare(publisher.topic_name, type_name)
        return TappedPublisher(self, publisher, index, cdr_encoder(type_name))

    def keep(self, index: int, data: bytes) -> None:
        """Keep a published message's CDR bytes for the next bundle."""
        with self._lock:
            self._kept.append((index, time.time_ns(), data))
            self._kept_bytes += len(data)
            full = (len(self._kept) >= MAX_PENDING_MESSAGES
                    or self._kept_bytes >= MAX_PENDING_BYTES)
        if full:
            self.flush()

    def left_out(self, exc: Exception) -> None:
        """Count and log a message that could not be encoded (never raised into the node's executor)."""
        self.unencodable += 1
        self._node.get_logger().warning(f'recording tap: a message left out of the recording ({exc!r})',
                                        throttle_duration_sec=5.0)

    def flush(self) -> None:
        """Send the kept messages as one bundle (an empty one at most every IDLE_PERIOD)."""
        active = self._bundle_pub.get_subscription_count() > 0
        now = time.monotonic()
        with self._flush_lock:
            with self._lock:
                self.active = active
                kept, self._kept, self._kept_bytes = self._kept, [], 0
            if not active or (not kept and now - self._last_sent < IDLE_PERIOD):
                return
            add = self._writer.add
            for index, publish_ns, data in kept:
                add(index, publish_ns, data)
            self._bundle_pub.publish(self._writer.take(time.time_ns()))
            self._last_sent = now
            self.bundles_sent += 1
