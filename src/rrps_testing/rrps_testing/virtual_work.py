"""An independent statics and dynamics for tests: leg forces by virtual work, from the anchors alone (eq. 1).

Nothing of rrps_kinematics or rrps_sim is used. At rest, J^T f = dU/dx (:func:`virtual_work_forces`): x = (p,
a small rotation vector) of the moving ring in the supporting ring's frame, J = dL/dx, U the potential energy
of the moving ring (with a point payload) and of the legs' links, both by central differences.
:func:`moving_ring_dynamics` (massless legs) also gives the holding ring's reaction by momentum balance.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['virtual_work_forces', 'moving_ring_dynamics', 'rotation_x', 'rotation_vector_matrix', 'quaternion_matrix']


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


def moving_ring_dynamics(geometry, support: str, gravity, R, p, omega, alpha, a_com,
                         *, step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """(actuator forces (6,), the structure's wrench (force, moment about the origin) on the
    holding ``support`` ring (6,)) with massless legs, the moving ring at (``R``, ``p``) in the
    holding ring's frame, turning at ``omega`` with ``alpha``, its com accelerating at ``a_com``,
    ``gravity`` in that frame: Newton-Euler of the moving ring balanced by the legs through virtual
    work (J^T f, J = dL/dx by central differences), and the whole robot's momentum balance about
    the holding ring's origin. The description's tool wrench acts on ring_b."""
    moving, held = ((geometry.ring_b_body, geometry.ring_a_body) if support == 'ring_a'
                    else (geometry.ring_a_body, geometry.ring_b_body))
    local, fixed = ((geometry.ring_b_anchors, geometry.ring_a_anchors) if support == 'ring_a'
                    else (geometry.ring_a_anchors, geometry.ring_b_anchors))
    g = np.asarray(gravity, dtype=float)
    c = p + R @ moving.com
    inertia = R @ moving.inertia @ R.T
    tool_f = tool_t = tcp = np.zeros(3)
    tool_on_moving = support == 'ring_a'
    if geometry.tool_wrench is not None:
        R_tool = quaternion_matrix(geometry.tool.quaternion_xyzw)
        R_b, p_b = (R, p) if tool_on_moving else (np.eye(3), np.zeros(3))
        tool_f, tool_t = R_b @ R_tool @ geometry.tool_wrench.force, R_b @ R_tool @ geometry.tool_wrench.torque
        tcp = R_b @ geometry.tool.position + p_b

    def lengths(x):                                  # com moved by x[:3], turned by x[3:] about it
        Rx = rotation_vector_matrix(x[3:]) @ R
        return np.linalg.norm(c + x[:3] + (local - moving.com) @ Rx.T - fixed, axis=1)

    J = np.column_stack([(lengths(step * e) - lengths(-step * e)) / (2 * step) for e in np.eye(6)])
    force = moving.mass * (a_com - g)
    moment = inertia @ alpha + np.cross(omega, inertia @ omega)
    F_s = force - held.mass * g
    M_s = np.cross(c, force) + moment - np.cross(held.com, held.mass * g)
    if geometry.tool_wrench is not None:
        F_s, M_s = F_s - tool_f, M_s - np.cross(tcp, tool_f) - tool_t
        if tool_on_moving:
            force, moment = force - tool_f, moment - np.cross(tcp - c, tool_f) - tool_t
    f = np.linalg.solve(J.T, np.concatenate([force, moment]))
    return f, np.concatenate([F_s, M_s])
