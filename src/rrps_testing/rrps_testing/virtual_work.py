"""An independent statics for tests: leg forces by virtual work, from the anchors alone (eq. 1).

At rest with ring_a gripping, the actuators' virtual work balances the change of potential
energy: J^T f = dU/dx, with x = (p, a small rotation vector of ring_b in ring_a), J = dL/dx the
leg lengths' Jacobian and U the potential energy of ring_b (its body, with a point payload at
``payload_com``) and of each leg's two links (their coms on the leg axis, the lower link's
``com_from_joint`` from the universal joint, the upper's from the spherical joint). Both by
central differences; nothing of rrps_kinematics or rrps_sim is used::

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


def virtual_work_forces(geometry, position, rotation, gravity, *, payload_mass: float = 0.0,
                        payload_com=(0.0, 0.0, 0.0), legs: bool = True, step: float = 1e-6) -> np.ndarray:
    """Leg forces [N] (6,) (+ pushing the rings apart) holding ring_b at ``position`` (3,) and
    ``rotation`` (3, 3) in ring_a's frame, ring_a gripping, ``gravity`` (3,) [m/s²] in ring_a's
    frame; ``legs=False``: massless legs."""
    A, B = geometry.ring_a_anchors, geometry.ring_b_anchors
    body = geometry.ring_b_body
    lo, up = geometry.lower_link, geometry.upper_link
    g = np.asarray(gravity, dtype=float)
    p0, R0 = np.asarray(position, dtype=float), np.asarray(rotation, dtype=float)
    c_payload = np.asarray(payload_com, dtype=float)

    def pose(x):
        return p0 + x[:3], rotation_vector_matrix(x[3:]) @ R0

    def lengths(x):
        p, R = pose(x)
        return np.linalg.norm(p + B @ R.T - A, axis=1)

    def energy(x):
        p, R = pose(x)
        tips = p + B @ R.T
        u = (tips - A) / np.linalg.norm(tips - A, axis=1)[:, None]
        weighted = body.mass * (p + R @ body.com) + payload_mass * (p + R @ c_payload)
        if legs:
            weighted = weighted + (lo.mass * (A + lo.com_from_joint * u)
                                   + up.mass * (tips - up.com_from_joint * u)).sum(axis=0)
        return -float(g @ weighted)

    J, dU = np.zeros((6, 6)), np.zeros(6)
    for k in range(6):
        e = np.zeros(6)
        e[k] = step
        J[:, k] = (lengths(e) - lengths(-e)) / (2 * step)
        dU[k] = (energy(e) - energy(-e)) / (2 * step)
    return np.linalg.solve(J.T, dU)
