"""Recording bundles: a node's published messages, batched for a recorder (pure, no ROS import).

A recording tap (:mod:`rrps_runtime.recording_tap`; docs/recording.md, "Recording taps") sends them every 0.1 s as one
``std_msgs/msg/UInt8MultiArray`` (empty layout) whose data is, little-endian, times the publisher's wall clock::

    MAGIC (8 bytes) | sent time [ns, int64] | node name (uint16 length + UTF-8)
    | topic count (uint16) | per topic, every tapped one: name, type (each uint16 length + UTF-8)
    | frames to the end: topic index (uint16), publish time [ns, int64], CDR length (uint32), CDR
"""

from __future__ import annotations

import dataclasses
import struct

from rrps_runtime.cdr import ENCAPSULATION

__all__ = ['MAGIC', 'Bundle', 'BundleWriter', 'decode_bundle', 'BUNDLE_TYPE']

MAGIC = b'RRPSTAP1'
#: The ROS type a bundle travels as.
BUNDLE_TYPE = 'std_msgs/msg/UInt8MultiArray'

# CDR of a UInt8MultiArray: encapsulation (CDR little-endian), layout.dim (empty sequence),
# layout.data_offset, then data as a uint32 length and the bytes.
_CDR_PREFIX = struct.Struct('<4sIII')
_FRAME = struct.Struct('<HqI')
_HEAD = struct.Struct('<8sqH')
_U16 = struct.Struct('<H')


@dataclasses.dataclass(frozen=True)
class Bundle:
    """A decoded bundle: who sent it, when, the topics it covers and its messages."""
    node: str
    sent_ns: int
    topics: tuple[tuple[str, str], ...]  # (topic name, type name), indexed by the frames
    frames: tuple[tuple[int, int, bytes], ...]  # (topic index, publish time [ns], CDR bytes)


def _text(value: str) -> bytes:
    data = value.encode('utf-8')
    if len(data) > 0xFFFF:
        raise ValueError(f'name too long for a bundle ({len(data)} bytes)')
    return _U16.pack(len(data)) + data


class BundleWriter:
    """Collects one node's frames and makes bundles of them. Not thread-safe (the tap locks)."""

    def __init__(self, node: str):
        self.node = node
        self._topics: list[tuple[str, str]] = []
        self._table = b''
        self._parts: list[bytes] = []

    def declare(self, topic: str, type_name: str) -> int:
        """Add a topic to the table; returns its index for :meth:`add`."""
        if len(self._topics) >= 0xFFFF:
            raise ValueError('too many topics for one bundle')
        self._topics.append((topic, type_name))
        self._table = _U16.pack(len(self._topics)) + b''.join(
            _text(name) + _text(kind) for name, kind in self._topics)
        return len(self._topics) - 1

    def add(self, index: int, publish_ns: int, data: bytes) -> None:
        """Queue one published message (its CDR bytes) of topic ``index``."""
        self._parts.append(_FRAME.pack(index, publish_ns, len(data)))
        self._parts.append(data)

    def take(self, sent_ns: int) -> bytes:
        """The CDR bytes of a UInt8MultiArray holding a bundle of every queued message; clears."""
        node = self.node.encode('utf-8')
        head = _HEAD.pack(MAGIC, sent_ns, len(node)) + node + self._table
        length = len(head) + sum(len(p) for p in self._parts)
        payload = b''.join([_CDR_PREFIX.pack(ENCAPSULATION, 0, 0, length), head, *self._parts])
        self._parts = []
        return payload


def decode_bundle(cdr: bytes) -> Bundle:
    """A bundle from the CDR bytes of its UInt8MultiArray; ValueError names what is malformed."""
    view = memoryview(cdr)
    if len(view) < _CDR_PREFIX.size:
        raise ValueError(f'bundle of {len(view)} bytes: shorter than its CDR header')
    encapsulation, dims, _, length = _CDR_PREFIX.unpack_from(view, 0)
    if encapsulation != ENCAPSULATION:
        raise ValueError(f'not a little-endian CDR message (encapsulation {bytes(encapsulation)!r})')
    if dims != 0:
        raise ValueError(f'a bundle has an empty layout, this array has {dims} dimensions')
    end = _CDR_PREFIX.size + length
    if end > len(view):
        raise ValueError(f'data of {length} bytes announced, {len(view) - _CDR_PREFIX.size} present')
    at = _CDR_PREFIX.size
    try:
        magic, sent_ns, node_length = _HEAD.unpack_from(view, at)
        if magic != MAGIC:
            raise ValueError(f'not a recording bundle (magic {bytes(magic)!r})')
        at += _HEAD.size
        node = bytes(view[at:at + node_length]).decode('utf-8')
        at += node_length
        (count,) = _U16.unpack_from(view, at)
        at += _U16.size
        topics = []
        for _ in range(count):
            names = []
            for _ in range(2):
                (n,) = _U16.unpack_from(view, at)
                at += _U16.size
                names.append(bytes(view[at:at + n]).decode('utf-8'))
                at += n
            topics.append((names[0], names[1]))
        frames = []
        while at < end:
            index, publish_ns, n = _FRAME.unpack_from(view, at)
            at += _FRAME.size
            if index >= count or at + n > end:
                raise ValueError(f'frame of topic {index} ({n} bytes) past the table or the data')
            frames.append((index, publish_ns, bytes(view[at:at + n])))
            at += n
    except struct.error as exc:
        raise ValueError(f'bundle cut short: {exc}') from None
    except UnicodeDecodeError as exc:
        raise ValueError(f'bundle name not UTF-8: {exc}') from None
    if at != end:
        raise ValueError('bundle cut inside its table')
    return Bundle(node, sent_ns, tuple(topics), tuple(frames))
