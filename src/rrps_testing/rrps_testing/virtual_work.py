"""An independent statics for tests: leg forces by virtual work, from the anchors alone (eq. 1).

At rest with one ring gripping, the actuators' virtual work balances the change of potential
energy: J^T f = dU/dx, with x = (p, a small rotation vector) of the moving ring in the supporting
ring's frame, J = dL/dx the leg lengths' Jacobian and U the potential energy of the moving ring
(its body, with a point payload) and of each leg's two links (their coms on the leg axis, the
lower link's ``com_from_joint`` from the universal joint, the upper's from the spherical joint).
Both by central differences; nothing of rrps_kinematics or rrps_sim is used::

    forces = virtual_work_forces(geometry, position, R, gravity_in_a, payload_mass=15.0)
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['virtual_work_forces', 'rotation_x', 'rotation_vector_matrix', 'quaternion_matrix']


def rotation_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_vector_matrix(v) -> np.ndarray:
    """Rodrigues' formula."""
    v = np.asarray(v, dtype=float)
    angle = float(np.linalg.norm(v))
    if angle < 1e-15:
        return np.eye(3)
    k = v / angle
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


def quaternion_matrix(q) -> np.ndarray:
    """Rotation of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def virtual_work_forces(geometry, position, rotation, gravity, *, support: str = 'ring_a',
                        payload_mass: float = 0.0, payload_ring: str = 'ring_b', payload_com=(0.0, 0.0, 0.0),
                        legs: bool = True, step: float = 1e-6) -> np.ndarray:
    """Leg forces [N] (6,) (+ pushing the rings apart) holding the robot at rest at a_T_b =
    (``position`` (3,), ``rotation`` (3, 3)) with the ``support`` ring gripping, ``gravity`` (3,)
    [m/s²] in the supporting ring's frame; a point ``payload_mass`` [kg] at ``payload_com`` in
    ``payload_ring``'s frame (on the supporting ring it loads the gripper, not the legs);
    ``legs=False``: massless legs."""
    fixed_b = support == 'ring_b'
    F, M = (geometry.ring_b_anchors, geometry.ring_a_anchors) if fixed_b else (
        geometry.ring_a_anchors, geometry.ring_b_anchors)
    body = geometry.ring_a_body if fixed_b else geometry.ring_b_body
    at_fixed, at_moving = (geometry.upper_link, geometry.lower_link) if fixed_b else (
        geometry.lower_link, geometry.upper_link)
    moving_payload = payload_mass if payload_ring != support else 0.0
    g = np.asarray(gravity, dtype=float)
    p_ab, R_ab = np.asarray(position, dtype=float), np.asarray(rotation, dtype=float)
    # the moving ring's pose in the supporting ring's frame
    p0, R0 = (-R_ab.T @ p_ab, R_ab.T) if fixed_b else (p_ab, R_ab)
    c_payload = np.asarray(payload_com, dtype=float)

    def pose(x):
        return p0 + x[:3], rotation_vector_matrix(x[3:]) @ R0

    def lengths(x):
        p, R = pose(x)
        return np.linalg.norm(p + M @ R.T - F, axis=1)

    def energy(x):
        p, R = pose(x)
        tips = p + M @ R.T
        u = (tips - F) / np.linalg.norm(tips - F, axis=1)[:, None]
        weighted = body.mass * (p + R @ body.com) + moving_payload * (p + R @ c_payload)
        if legs:
            weighted = weighted + (at_fixed.mass * (F + at_fixed.com_from_joint * u)
                                   + at_moving.mass * (tips - at_moving.com_from_joint * u)).sum(axis=0)
        return -float(g @ weighted)

    J, dU = np.zeros((6, 6)), np.zeros(6)
    for k in range(6):
        e = np.zeros(6)
        e[k] = step
        J[:, k] = (lengths(e) - lengths(-e)) / (2 * step)
        dU[k] = (energy(e) - energy(-e)) / (2 * step)
    return np.linalg.solve(J.T, dU)
