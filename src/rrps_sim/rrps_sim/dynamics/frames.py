"""The DAE's coordinates in the supporting ring's frame, and the pose a_T_b back from them
(with ring_b supporting, body 0 is ring_a: :func:`supported_pose` turns b_T_a into a_T_b)."""

from __future__ import annotations

import numpy as np

from rrps_description.rotations import (
    euler_parameters_to_quat_xyzw,
    normalize_quat,
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    quat_xyzw_to_euler_parameters,
    quat_xyzw_to_matrix,
)
from rrps_description.world import Support

__all__ = ['grounded_coordinates', 'supported_pose']


def grounded_coordinates(q_a: np.ndarray, support: Support, ring_b_com: np.ndarray,
                         ring_a_com: np.ndarray) -> np.ndarray:
    """The 91 coordinates ``q_a`` (ring_a's frame, body 0 ring_b) in the supporting ring's
    frame with body 0 the free ring; the ring coms in their own frames."""
    if support.index == 0:
        return q_a
    bodies = q_a.reshape(13, 7)
    quat_ab = euler_parameters_to_quat_xyzw(bodies[0, 3:])
    R = quat_xyzw_to_matrix(quat_ab)
    t = bodies[0, :3] - R @ ring_b_com
    turn = quat_conjugate_xyzw(quat_ab)
    out = np.empty((13, 7))
    out[:, :3] = (bodies[:, :3] - t) @ R
    out[:, 3:] = quat_xyzw_to_euler_parameters(
        quat_multiply_xyzw(np.broadcast_to(turn, (13, 4)), euler_parameters_to_quat_xyzw(bodies[:, 3:])))
    out[0, :3] = (ring_a_com - t) @ R
    out[0, 3:] = quat_xyzw_to_euler_parameters(turn)
    return out.reshape(91)


def supported_pose(position: np.ndarray, euler_parameters: np.ndarray,
                   support: Support) -> tuple[np.ndarray, np.ndarray]:
    """a_T_b (positions (K, 3), unit quaternions (K, 4) x, y, z, w, w >= 0) from the hub's
    observed origin and Euler parameters in the ground's frame."""
    quat = normalize_quat(euler_parameters_to_quat_xyzw(euler_parameters))
    if support.index == 0:
        return position, quat
    quat_ab = normalize_quat(quat_conjugate_xyzw(quat))
    return -np.einsum('...ij,...j->...i', quat_xyzw_to_matrix(quat_ab), position), quat_ab
