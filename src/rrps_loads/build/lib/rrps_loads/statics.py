"""Statics of an RRPS robot at rest on either ring (paper eq. 19 at rest), by virtual work.

The supporting ring grips the structure; the other, *free* ring hangs on the six legs. With the
twist of ring_b relative to ring_a as the six generalized velocities (the twist of the inverse
Jacobian J, eq. 1), the actuators' wrench J^T f on ring_b at its origin (ring_a's frame) is
reacted on ring_a as -J^T f, so at rest

    ring_a supports:  J^T f = -W_b        ring_b supports:  J^T f = W_a

with W the wrench (about ring_b's origin, ring_a's frame) of everything the free ring carries:
its weight and payload, the tool wrench when ring_b is free, and each leg's weight. A leg's
weight reaches the rings at its two joints: with k = (m_l c_l - m_u c_u) / L and g⊥ gravity
normal to the leg, w_i = m_u g + k g⊥ at the spherical joint (on ring_b) and w'_i = m_l g - k g⊥
at the universal joint (on ring_a), w_i + w'_i = (m_l + m_u) g: the links' moment balance about
their joints (the prismatic pair turns the leg as one body, the spherical joint carries no
moment, and the universal joint's torque has no part along the leg: it vanishes at rest).
Gravity is the world's, in ring_a's frame at each pose (:mod:`rrps_loads.support`). Forces are
positive when they push the rings apart; :mod:`rrps_loads.loads` adds the joint reactions.
"""

from __future__ import annotations

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import cross
from rrps_kinematics.errors import SingularPoseError
from rrps_kinematics.inverse import InverseKinematicsResult
from rrps_kinematics.jacobian import inverse_jacobian
from rrps_loads.reduced import PlatformPose, assembled_pose
from rrps_loads.support import Support, WorldLoads, support_of, world_loads

__all__ = ['leg_weight_shares', 'static_load', 'holding_forces', 'solve_actuator_forces',
           'SINGULAR_CONDITIONING']

# Inverse condition number of the unit-consistent Jacobian below which a pose counts as singular.
SINGULAR_CONDITIONING = 1e-9


def solve_actuator_forces(pose: PlatformPose, load: np.ndarray) -> np.ndarray:
    """Actuator forces f (N, 6) with J^T f = load (N, 6); SingularPoseError at a singular pose."""
    return solve_transposed(pose.inverse_jacobian, pose.geometry, load)


def solve_transposed(J: np.ndarray, geometry: RobotGeometry, load: np.ndarray) -> np.ndarray:
    """f with J^T f = load. Singularity is judged on the unit-consistent Jacobian (angular
    columns divided by the robot's characteristic length), so the threshold does not depend on
    the robot's size."""
    scale = np.concatenate([np.ones(3), np.full(3, 1.0 / geometry.characteristic_length)])
    s = np.linalg.svd(J * scale, compute_uv=False)
    conditioning = s[:, -1] / s[:, 0]
    bad = np.flatnonzero(~(conditioning > SINGULAR_CONDITIONING))
    if bad.size:
        raise SingularPoseError(f'singular pose (sample {int(bad[0])}: inverse condition number '
                                f'{conditioning[bad[0]]:.3g}): no finite actuator forces hold it')
    return np.linalg.solve(np.swapaxes(J, -1, -2), np.asarray(load, dtype=float)[..., None])[..., 0]


def leg_weight_shares(geometry: RobotGeometry, ik: InverseKinematicsResult,
                      gravity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(w, w') (N, 6, 3) [N]: each leg's weight as forces at its spherical joint (on ring_b) and
    at its universal joint (on ring_a), for gravity (N, 3) in ring_a's frame."""
    u, lengths = ik.unit_vectors, ik.lengths
    lo, up = geometry.lower_link, geometry.upper_link
    g = gravity[:, None, :]
    g_normal = g - u * np.einsum('nij,nj->ni', u, gravity)[..., None]
    k = ((lo.mass * lo.com_from_joint - up.mass * up.com_from_joint) / lengths)[..., None]
    return up.mass * g + k * g_normal, lo.mass * g - k * g_normal


def static_load(geometry: RobotGeometry, ik: InverseKinematicsResult, support: Support,
                loads: WorldLoads) -> np.ndarray:
    """The load Q (N, 6) [N, N m] with J^T f = Q at rest (module docstring), for the world's
    ``loads`` in ring_a's frame at the poses of ``ik``."""
    g = loads.gravity
    p = ik.position
    w_b, w_a = leg_weight_shares(geometry, ik, g)
    if support.index == 0:
        body = geometry.ring_b_body
        com = np.einsum('nij,j->ni', ik.rotation, body.com)                     # about p
        force = body.mass * g + w_b.sum(axis=1) + loads.tool_force
        moment = (body.mass * cross(com, g) + cross(ik.ring_b_anchors_in_a - p[:, None, :], w_b).sum(axis=1)
                  + cross(loads.tool_point - p, loads.tool_force) + loads.tool_torque)
        return -np.concatenate([force, moment], axis=-1)
    body = geometry.ring_a_body
    force = body.mass * g + w_a.sum(axis=1)
    moment = (body.mass * cross(body.com - p, g)
              + cross(geometry.ring_a_anchors - p[:, None, :], w_a).sum(axis=1))
    return np.concatenate([force, moment], axis=-1)


def holding_forces(geometry: RobotGeometry, position, quaternion_xyzw, *, support='ring_a',
                   world_q_support=None, gravity=None) -> np.ndarray:
    """Actuator forces [N] (6,) holding the robot at rest at a pose, legs included.

    ``position`` (3,) [m] and ``quaternion_xyzw`` (4,) give a_T_b; batches (N, 3), (N, 4) give
    (N, 6). ``support``: the gripping ring, turned by ``world_q_support`` (x, y, z, w; default
    upright) in a world of ``gravity`` (default (0, 0, -9.81) m/s²). Raises ValueError for
    invalid input, SingularPoseError (a ValueError too) for a locked universal joint or a
    singular pose.
    """
    world = support_of(support, world_q_support, gravity)
    single = np.ndim(position) == 1
    ik, _, _ = assembled_pose(geometry, position, quaternion_xyzw)
    load = static_load(geometry, ik, world, world_loads(geometry, world, ik.position, ik.rotation))
    forces = solve_transposed(inverse_jacobian(ik), geometry, load)
    return forces[0] if single else forces
