"""Conversions between the rrps values and ROS messages (poses, leg states, odometry, stamps)."""

from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np
from geometry_msgs.msg import PoseStamped, TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from rrps_description.names import LEG_NAMES

__all__ = ['stamp_to_seconds', 'pose_from_msg', 'pose_to_msg', 'transform_from_msg', 'transform_to_msg',
           'joint_state_msg', 'lengths_from_joint_state', 'odometry_msg']


def stamp_to_seconds(stamp) -> float:
    """builtin_interfaces/Time -> float seconds."""
    return stamp.sec + 1e-9 * stamp.nanosec


def pose_from_msg(msg: PoseStamped) -> tuple[np.ndarray, np.ndarray]:
    """PoseStamped -> (position (3,), quaternion_xyzw (4,)), unvalidated floats."""
    p = msg.pose.position
    q = msg.pose.orientation
    return np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w])


def pose_to_msg(position: Sequence[float], quaternion_xyzw: Sequence[float], *, frame_id: str,
                stamp) -> PoseStamped:
    """(position, quaternion_xyzw) -> PoseStamped in ``frame_id``."""
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
    (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
     msg.pose.orientation.w) = (float(v) for v in quaternion_xyzw)
    return msg


def transform_from_msg(msg: TransformStamped) -> tuple[np.ndarray, np.ndarray]:
    """TransformStamped -> (translation (3,), quaternion_xyzw (4,)), unvalidated floats."""
    t = msg.transform.translation
    q = msg.transform.rotation
    return np.array([t.x, t.y, t.z]), np.array([q.x, q.y, q.z, q.w])


def transform_to_msg(position: Sequence[float], quaternion_xyzw: Sequence[float], *, frame_id: str,
                     child_frame_id: str, stamp) -> TransformStamped:
    """(position, quaternion_xyzw) of ``child_frame_id`` in ``frame_id`` -> TransformStamped."""
    msg = TransformStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.child_frame_id = child_frame_id
    t, q = msg.transform.translation, msg.transform.rotation
    t.x, t.y, t.z = (float(v) for v in position)
    q.x, q.y, q.z, q.w = (float(v) for v in quaternion_xyzw)
    return msg


def joint_state_msg(stamp, positions: Iterable[float], velocities: Iterable[float] | None = None,
                    efforts: Iterable[float] | None = None,
                    names: Sequence[str] = LEG_NAMES) -> JointState:
    """A JointState for the six legs: position = lengths [m], velocity [m/s], effort [N]."""
    msg = JointState()
    msg.header.stamp = stamp
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    if velocities is not None:
        msg.velocity = [float(v) for v in velocities]
    if efforts is not None:
        msg.effort = [float(v) for v in efforts]
    return msg


def lengths_from_joint_state(msg: JointState, names: Sequence[str] = LEG_NAMES) -> np.ndarray:
    """Leg lengths in leg order from a JointState, matched by name (any order).

    Raises ValueError naming what is wrong: missing or duplicated names, sizes that differ,
    NaN or infinite values. An unnamed message with exactly six positions is taken in order.
    """
    if len(msg.position) == len(names) and tuple(msg.name) == tuple(names):  # the usual message
        values = np.array(msg.position, dtype=float)
        if not np.isfinite(values).all():
            raise ValueError('positions contain NaN or infinite values')
        return values
    positions = list(msg.position)
    if not msg.name:
        if len(positions) != len(names):
            raise ValueError(f'expected {len(names)} positions, got {len(positions)}')
        values = np.asarray(positions, dtype=float)
    else:
        if len(msg.name) != len(positions):
            raise ValueError(f'{len(msg.name)} names but {len(positions)} positions')
        if len(set(msg.name)) != len(msg.name):
            raise ValueError('duplicated joint names')
        index = {n: i for i, n in enumerate(msg.name)}
        missing = [n for n in names if n not in index]
        if missing:
            raise ValueError(f'missing joints {missing}')
        values = np.array([positions[index[n]] for n in names], dtype=float)
    if not np.all(np.isfinite(values)):
        raise ValueError('positions contain NaN or infinite values')
    return values


def odometry_msg(estimate, *, stamp, frame_id: str, child_frame_id: str) -> Odometry:
    """A :class:`rrps_kinematics.base_odometry.OdometryEstimate` as nav_msgs/Odometry: the pose of
    ``child_frame_id`` in ``frame_id``, the twist in ``child_frame_id``, covariances row-major."""
    msg = Odometry()
    msg.header.stamp, msg.header.frame_id, msg.child_frame_id = stamp, frame_id, child_frame_id
    pose = msg.pose.pose
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in estimate.pose.position)
    (pose.orientation.x, pose.orientation.y, pose.orientation.z,
     pose.orientation.w) = (float(v) for v in estimate.pose.quaternion_xyzw)
    twist = msg.twist.twist
    twist.linear.x, twist.linear.y, twist.linear.z = (float(v) for v in estimate.twist[:3])
    twist.angular.x, twist.angular.y, twist.angular.z = (float(v) for v in estimate.twist[3:])
    msg.pose.covariance = [float(v) for v in np.ravel(estimate.pose_covariance)]
    msg.twist.covariance = [float(v) for v in np.ravel(estimate.twist_covariance)]
    return msg
