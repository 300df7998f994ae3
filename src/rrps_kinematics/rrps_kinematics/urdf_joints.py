"""Every URDF joint's value from a pose a_T_b (the IK of eq. 1), and the robot's URDF; no ROS.

Per leg (:func:`rrps_description.urdf.leg_chain`): the universal-joint angles, the length and the
spherical joint's angles ``J = Rz(twist) Rx(x) Ry(y)`` of its socket frame seen from the upper link,
which put every tip on its ring_b anchor. Extra ring DOF angles (§3.1) are measured (``ring_angles``)."""

from __future__ import annotations

from typing import Mapping

import numpy as np

from rrps_description.geometry import RobotGeometry, per_geometry
from rrps_description.pose import Pose
from rrps_description.urdf import RobotModel, leg_chain, socket_frames, urdf_model
from rrps_kinematics.inverse import inverse_kinematics, universal_joint_frames

__all__ = ['robot_model', 'robot_urdf', 'joint_values', 'spherical_angles']

#: Each leg's moving joints in chain order (universal x, y, prismatic, spherical z, x, y), legs 1..6.
_LEG_JOINTS = tuple(name for leg in range(1, 7) for name in leg_chain(leg).joints)


@per_geometry
def robot_model(geometry: RobotGeometry) -> RobotModel:
    """The URDF model of ``geometry`` (built once per geometry object)."""
    return urdf_model(geometry, universal_joint_frames(geometry))


def robot_urdf(geometry: RobotGeometry) -> str:
    """The URDF text of ``geometry``."""
    return robot_model(geometry).xml()


def spherical_angles(J: np.ndarray) -> np.ndarray:
    """z-x-y angles (twist, x, y) of rotations ``J = Rz(twist) Rx(x) Ry(y)``, (..., 3, 3) -> (..., 3)."""
    twist = np.arctan2(-J[..., 0, 1], J[..., 1, 1])
    x = np.arctan2(J[..., 2, 1], np.hypot(J[..., 2, 0], J[..., 2, 2]))
    y = np.arctan2(-J[..., 2, 0], J[..., 2, 2])
    return np.stack([twist, x, y], axis=-1)


def joint_values(geometry: RobotGeometry, a_T_b: Pose,
                 ring_angles: Mapping[str, float] | None = None) -> dict[str, float]:
    """Every moving URDF joint's value [rad or m] for ring_b at ``a_T_b``, in the URDF's order;
    a ring's extra-DOF joint (``ring_a_rotation``, ``ring_b_rotation``) only when its angle is
    in ``ring_angles``."""
    ik = inverse_kinematics(geometry, a_T_b.position, a_T_b.quaternion_xyzw)
    lower = ik.lower_link_rotations  # (6, 3, 3): a_R_lower (= a_R_upper)
    J = np.swapaxes(lower, -1, -2) @ a_T_b.rotation @ socket_frames(geometry)
    spherical = spherical_angles(J)
    legs = np.concatenate([ik.universal_angles, ik.lengths[:, None], spherical], axis=1)  # (6, 6)
    values = dict(zip(_LEG_JOINTS, legs.ravel().tolist()))
    rings = dict(ring_angles or {})
    for name in robot_model(geometry).moving_joints:
        if name not in values and name in rings:
            values[name] = float(rings[name])
    return values
