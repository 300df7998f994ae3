"""A node's recording tap: its high-rate publications, batched for a recorder (docs/recording.md, "Recording taps").

A node creates those publishers with :meth:`RecordingTap.create_publisher`. While a recorder subscribes to
``~/recording_tap``, each published message is also kept and every ``FLUSH_PERIOD`` the kept ones go out as one
bundle (:mod:`rrps_runtime.recording_bundle`). JointState, PoseStamped and WrenchStamped are encoded only then, so a
node must not change such a message after publishing it while :attr:`TappedPublisher.tapped`.
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
        self._encode = encode

    @property
    def tapped(self) -> bool:
        """True while a recorder listens: a published message is kept until the next bundle."""
        return self._tap.active

    def publish(self, msg) -> None:
        """Publish ``msg``; while tapped, keep it for the next bundle (serialised now unless its type has a CDR
        encoder: then it is encoded with the bundle and must not be changed after it is published)."""
        if not self._tap.active:
            self.publisher.publish(msg)
        elif self._encode is None:
            data = serialize_message(msg)
            self.publisher.publish(data)
            self._tap.keep(self._index, data, None)
        else:
            self.publisher.publish(msg)
            self._tap.keep(self._index, msg, self._encode)


class RecordingTap:
    """One node's bundle of tapped publications; see the module docstring."""

    def __init__(self, node: Node, *, flush_period: float = FLUSH_PERIOD):
        self._writer = BundleWriter(node.get_fully_qualified_name())
        self._kept: list[tuple[int, int, object, object]] = []  # (topic, publish ns, message, encode)
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

    def keep(self, index: int, item, encode) -> None:
        """Keep a published message for the next bundle: ``encode(item)`` gives its CDR bytes,
        or ``item`` is those bytes when ``encode`` is None."""
        with self._lock:
            self._kept.append((index, time.time_ns(), item, encode))
            if encode is None:
                self._kept_bytes += len(item)
            full = (len(self._kept) >= MAX_PENDING_MESSAGES
                    or self._kept_bytes >= MAX_PENDING_BYTES)
        if full:
            self.flush()

    def flush(self) -> None:
        """Send the kept messages as one bundle (an empty one at most every IDLE_PERIOD). A message that cannot be
        encoded is left out and logged, never raised into the node's executor."""
        active = self._bundle_pub.get_subscription_count() > 0
        now = time.monotonic()
        with self._flush_lock:
            with self._lock:
                self.active = active
                kept, self._kept, self._kept_bytes = self._kept, [], 0
            if not active or (not kept and now - self._last_sent < IDLE_PERIOD):
                return
            add = self._writer.add
            for index, publish_ns, item, encode in kept:
                try:
                    add(index, publish_ns, item if encode is None else encode(item))
                except (AttributeError, TypeError, ValueError, struct.error) as exc:
                    self.unencodable += 1
                    self._node.get_logger().warning(
                        f'recording tap: a message left out of the recording ({exc!r})',
                        throttle_duration_sec=5.0)
            self._bundle_pub.publish(self._writer.take(time.time_ns()))
            self._last_sent = now
            self.bundles_sent += 1
