"""CDR bytes of the stack's high-rate message types and of ``/tf``, by ``rosbags``' serializer (pure, no ROS import).

For the recording taps (:mod:`rrps_runtime.recording_tap`): an rclpy message is copied into rosbags' class of its type
(from rclpy's ``_field`` slots) and serialised as little-endian XCDR1 with zero padding, which rosbags' reader accepts
(rclpy's ``serialize_message`` leaves the padding unset). Cost: docs/measurements.md, "Recording".
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from rosbags.typesys import Stores, get_typestore

__all__ = ['cdr_encoder', 'joint_state_cdr', 'pose_stamped_cdr', 'wrench_stamped_cdr', 'tf_message_cdr']

_STORE = get_typestore(Stores.ROS2_JAZZY)
_types = _STORE.types
_Time, _Header = _types['builtin_interfaces/msg/Time'], _types['std_msgs/msg/Header']
_JointState, _PoseStamped = _types['sensor_msgs/msg/JointState'], _types['geometry_msgs/msg/PoseStamped']
_Pose, _Point, _Quaternion = (_types[f'geometry_msgs/msg/{t}'] for t in ('Pose', 'Point', 'Quaternion'))
_WrenchStamped, _Wrench, _Vector3 = (_types[f'geometry_msgs/msg/{t}'] for t in ('WrenchStamped', 'Wrench', 'Vector3'))
_TFMessage, _TransformStamped, _Transform = (_types[t] for t in (
    'tf2_msgs/msg/TFMessage', 'geometry_msgs/msg/TransformStamped', 'geometry_msgs/msg/Transform'))


def _bytes(message, type_name: str) -> bytes:
    return _STORE.serialize_cdr(message, type_name).tobytes()


def _header(header) -> object:
    stamp = header._stamp
    return _Header(stamp=_Time(sec=stamp._sec, nanosec=stamp._nanosec), frame_id=header._frame_id)


def _vector(v) -> object:
    return _Vector3(x=v._x, y=v._y, z=v._z)


def joint_state_cdr(msg) -> bytes:
    """CDR bytes of an rclpy ``sensor_msgs/msg/JointState``."""
    return _bytes(_JointState(header=_header(msg._header), name=list(msg._name),
                              position=np.asarray(msg._position, dtype=np.float64),
                              velocity=np.asarray(msg._velocity, dtype=np.float64),
                              effort=np.asarray(msg._effort, dtype=np.float64)), 'sensor_msgs/msg/JointState')


def pose_stamped_cdr(msg) -> bytes:
    """CDR bytes of an rclpy ``geometry_msgs/msg/PoseStamped``."""
    p, q = msg._pose._position, msg._pose._orientation
    return _bytes(_PoseStamped(header=_header(msg._header), pose=_Pose(
        position=_Point(x=p._x, y=p._y, z=p._z), orientation=_Quaternion(x=q._x, y=q._y, z=q._z, w=q._w))),
        'geometry_msgs/msg/PoseStamped')


def wrench_stamped_cdr(msg) -> bytes:
    """CDR bytes of an rclpy ``geometry_msgs/msg/WrenchStamped``."""
    w = msg._wrench
    return _bytes(_WrenchStamped(header=_header(msg._header), wrench=_Wrench(force=_vector(w._force),
                                                                              torque=_vector(w._torque))),
                  'geometry_msgs/msg/WrenchStamped')


def tf_message_cdr(stamp_ns: int, frames) -> bytes:
    """CDR bytes of a ``tf2_msgs/msg/TFMessage`` (without the tf2_msgs package) of ``frames``:
    (parent, child, translation (3,), rotation x, y, z, w (4,)), all stamped ``stamp_ns``."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    stamp = _Time(sec=sec, nanosec=nanosec)
    return _bytes(_TFMessage(transforms=[
        _TransformStamped(header=_Header(stamp=stamp, frame_id=parent), child_frame_id=child,
                          transform=_Transform(translation=_Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])),
                                               rotation=_Quaternion(x=float(r[0]), y=float(r[1]), z=float(r[2]),
                                                                    w=float(r[3]))))
        for parent, child, t, r in frames]), 'tf2_msgs/msg/TFMessage')


_ENCODERS = {
    'sensor_msgs/msg/JointState': joint_state_cdr,
    'geometry_msgs/msg/PoseStamped': pose_stamped_cdr,
    'geometry_msgs/msg/WrenchStamped': wrench_stamped_cdr,
}


def cdr_encoder(type_name: str) -> Callable[[object], bytes] | None:
    """The encoder of ``type_name`` (e.g. 'sensor_msgs/msg/JointState'), None for other types."""
    return _ENCODERS.get(type_name)
