"""Helpers shared by the node tests: messages for the chain and the nodes' /diagnostics."""

from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped

from rrps_description.rotations import quat_xyzw_to_matrix, rotation_angle_between
from rrps_interfaces.status import source_node
from rrps_runtime.messages import joint_state_msg, pose_from_msg, pose_to_msg


def target(node, position, quaternion_xyzw=(0.0, 0.0, 0.0, 1.0), *, frame_id='ring_a', age=0.0) -> PoseStamped:
    """A target pose stamped ``age`` seconds ago by ``node``'s clock."""
    now = node.get_clock().now().nanoseconds - int(age * 1e9)
    msg = pose_to_msg(position, quaternion_xyzw, frame_id=frame_id, stamp=node.get_clock().now().to_msg())
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 10**9)
    return msg


def command(node, lengths, *, age=0.0, names=None):
    """An actuators/command JointState stamped ``age`` seconds ago."""
    kwargs = {} if names is None else {'names': names}
    msg = joint_state_msg(node.get_clock().now().to_msg(), lengths, **kwargs)
    now = node.get_clock().now().nanoseconds - int(age * 1e9)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 10**9)
    return msg


def statuses(diagnostics: list[DiagnosticArray], node_name: str) -> list:
    """Every DiagnosticStatus received from ``node_name``."""
    return [s for array in list(diagnostics) for s in array.status if source_node(s.name) == node_name]


def said(diagnostics, node_name: str, text: str) -> bool:
    """Whether a status of ``node_name`` contained ``text``."""
    return any(text in s.message for s in statuses(diagnostics, node_name))


def pose_error(msg: PoseStamped, position, quaternion_xyzw) -> tuple[float, float]:
    """(translation error [m], rotation angle error [rad]) of a PoseStamped against a pose."""
    p, q = pose_from_msg(msg)
    angle = rotation_angle_between(quat_xyzw_to_matrix(q / np.linalg.norm(q)),
                                   quat_xyzw_to_matrix(np.asarray(quaternion_xyzw, dtype=float)))
    return float(np.linalg.norm(p - np.asarray(position))), float(angle)
