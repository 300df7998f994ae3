"""CDR bytes of the stack's high-rate message types and of ``/tf`` (pure, no ROS import).

JointState, PoseStamped and WrenchStamped, which a recording tap publishes as the bytes it records
(:mod:`rrps_runtime.recording_tap`, up to 500 a second per stream), are written from the message's
fields with ``struct``, caching what does not change from one message to the next (a JointState's
frame and joint names, a PoseStamped's frame): rosbags' serializer, which copies the message into
its own class first, missed the recorder's cost budget (``benchmarks/tap_cost.py`` and
``benchmarks/recorder.py``, same-run figures in docs/measurements.md, "Recording"). ``/tf``, 10 Hz,
goes through rosbags' serializer.

Encoding: XCDR1 little-endian, as rclpy and MCAP's ros2 profile use it. A 4-byte encapsulation
header, then each field aligned to its own size (strings and sequence lengths to 4, float64 to
8) counted from the end of that header; strings as a uint32 length (with the NUL), the UTF-8
bytes and a NUL; padding is zeros (rclpy's ``serialize_message`` leaves it unset, and 8 bytes past
a JointState whose last sequence is empty, which rosbags' reader refuses). The tests compare every
encoder with mcap-ros2's and rclpy's own.
"""

from __future__ import annotations

import struct
import sys
from array import array
from typing import Callable

from rosbags.typesys import Stores, get_typestore

__all__ = ['ENCAPSULATION', 'cdr_encoder', 'joint_state_cdr', 'pose_stamped_cdr', 'wrench_stamped_cdr',
           'tf_message_cdr']

_STORE = get_typestore(Stores.ROS2_JAZZY)
_types = _STORE.types
_Time, _Header = _types['builtin_interfaces/msg/Time'], _types['std_msgs/msg/Header']
_Vector3, _Quaternion = _types['geometry_msgs/msg/Vector3'], _types['geometry_msgs/msg/Quaternion']
_TFMessage, _TransformStamped, _Transform = (_types[t] for t in (
    'tf2_msgs/msg/TFMessage', 'geometry_msgs/msg/TransformStamped', 'geometry_msgs/msg/Transform'))

#: CDR, little-endian, no options.
ENCAPSULATION = b'\x00\x01\x00\x00'
_U32 = struct.Struct('<I')
_STAMP = struct.Struct('<iI')
_POSE = struct.Struct('<7d')
_WRENCH = struct.Struct('<6d')
_LITTLE_ENDIAN_HOST = sys.byteorder == 'little'
#: Cached frame and name blocks are dropped past this many (a node whose names keep changing).
_CACHE_LIMIT = 64
_ZEROS = [bytes(n) for n in range(8)]


def _pad(out: bytearray, size: int) -> None:
    """Zero-pad ``out`` (which starts with the encapsulation header) to a ``size`` boundary."""
    out += _ZEROS[-(len(out) - len(ENCAPSULATION)) % size]


def _append_string(out: bytearray, text: str) -> None:
    """Append a CDR string: aligned to 4, uint32 length including the NUL, UTF-8 bytes, NUL."""
    data = text.encode('utf-8') + b'\x00'
    _pad(out, 4)
    out += _U32.pack(len(data))
    out += data


def _float64_sequence(out: bytearray, values) -> None:
    """Append a float64 sequence: uint32 count (aligned to 4), then the values (aligned to 8)."""
    count = len(values)
    offset = len(out) - len(ENCAPSULATION)
    head = -offset % 4
    if not count:
        out += _ZEROS[head] + _U32.pack(0)
        return
    if _LITTLE_ENDIAN_HOST and isinstance(values, array) and values.typecode == 'd':
        data = values.tobytes()
    else:
        data = struct.pack(f'<{count}d', *values)
    out += _ZEROS[head] + _U32.pack(count) + _ZEROS[-(offset + head + 4) % 8] + data


_joint_state_blocks: dict[tuple[str, tuple[str, ...]], bytes] = {}
_frame_blocks: dict[str, bytes] = {}


def _names_block(frame_id: str, names: tuple[str, ...]) -> bytes:
    """Encapsulation, a zero stamp, frame_id and the names sequence: a JointState's fixed part."""
    out = bytearray(ENCAPSULATION + bytes(_STAMP.size))
    _append_string(out, frame_id)
    _pad(out, 4)
    out += _U32.pack(len(names))
    for name in names:
        _append_string(out, name)
    return bytes(out)


def _frame_block(frame_id: str) -> bytes:
    """Encapsulation, a zero stamp and frame_id, padded to 8 for the float64 fields after it."""
    out = bytearray(ENCAPSULATION + bytes(_STAMP.size))
    _append_string(out, frame_id)
    _pad(out, 8)
    return bytes(out)


def _cached(cache: dict, key, build, *args) -> bytes:
    block = cache.get(key)
    if block is None:
        if len(cache) >= _CACHE_LIMIT:
            cache.clear()
        block = cache[key] = build(*args)
    return block


# The encoders read rclpy's message slots (rosidl_generator_py stores field ``f`` in ``_f``)
# rather than its properties, which is most of the cost saved.

def joint_state_cdr(msg) -> bytes:
    """CDR bytes of a ``sensor_msgs/msg/JointState``."""
    header = msg._header
    stamp = header._stamp
    names = tuple(msg._name)
    block = _cached(_joint_state_blocks, (header._frame_id, names), _names_block,
                    header._frame_id, names)
    out = bytearray(block)
    out[4:12] = _STAMP.pack(stamp._sec, stamp._nanosec)
    _float64_sequence(out, msg._position)
    _float64_sequence(out, msg._velocity)
    _float64_sequence(out, msg._effort)
    return bytes(out)


def _stamped(header, body: bytes) -> bytes:
    """A header (stamp, frame_id) and the float64 fields after it."""
    stamp = header._stamp
    block = _cached(_frame_blocks, header._frame_id, _frame_block, header._frame_id)
    return b''.join((block[:4], _STAMP.pack(stamp._sec, stamp._nanosec), block[12:], body))


def pose_stamped_cdr(msg) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/PoseStamped``."""
    pose = msg._pose
    p, q = pose._position, pose._orientation
    return _stamped(msg._header, _POSE.pack(p._x, p._y, p._z, q._x, q._y, q._z, q._w))


def wrench_stamped_cdr(msg) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/WrenchStamped``."""
    wrench = msg._wrench
    f, t = wrench._force, wrench._torque
    return _stamped(msg._header, _WRENCH.pack(f._x, f._y, f._z, t._x, t._y, t._z))


def tf_message_cdr(stamp_ns: int, frames) -> bytes:
    """CDR bytes of a ``tf2_msgs/msg/TFMessage`` (without the tf2_msgs package) of ``frames``:
    (parent, child, translation (3,), rotation x, y, z, w (4,)), all stamped ``stamp_ns``."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    stamp = _Time(sec=sec, nanosec=nanosec)
    return _STORE.serialize_cdr(_TFMessage(transforms=[
        _TransformStamped(header=_Header(stamp=stamp, frame_id=parent), child_frame_id=child,
                          transform=_Transform(translation=_Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])),
                                               rotation=_Quaternion(x=float(r[0]), y=float(r[1]), z=float(r[2]),
                                                                    w=float(r[3]))))
        for parent, child, t, r in frames]), 'tf2_msgs/msg/TFMessage').tobytes()


_ENCODERS = {
    'sensor_msgs/msg/JointState': joint_state_cdr,
    'geometry_msgs/msg/PoseStamped': pose_stamped_cdr,
    'geometry_msgs/msg/WrenchStamped': wrench_stamped_cdr,
}


def cdr_encoder(type_name: str) -> Callable[[object], bytes] | None:
    """The encoder of ``type_name`` (e.g. 'sensor_msgs/msg/JointState'), None for other types."""
    return _ENCODERS.get(type_name)
