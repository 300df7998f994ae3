"""Statics of an RRPS platform: actuator forces that hold a pose against gravity (paper eq. 19
at rest), by virtual work: the closed form of :func:`gravity_load`, checked against the reduced
model of :mod:`rrps_sim.reduced`.

At rest eq. 19 leaves J^T f = Q_g, with Q_g the generalized load of gravity on ring_b and on
every leg link (component k: the power of -m g on each body for the unit twist e_k of ring_b).
Forces are positive when they push the rings apart.
"""

from __future__ import annotations

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import cross
from rrps_kinematics.errors import SingularPoseError
from rrps_kinematics.inverse import InverseKinematicsResult
from rrps_kinematics.jacobian import inverse_jacobian
from rrps_sim.reduced import PlatformPose, assembled_pose

__all__ = ['gravity_load', 'holding_forces', 'solve_actuator_forces', 'SINGULAR_CONDITIONING']

# Inverse condition number of the unit-consistent Jacobian below which a pose counts as singular.
SINGULAR_CONDITIONING = 1e-9


def solve_actuator_forces(pose: PlatformPose, load: np.ndarray) -> np.ndarray:
    """Actuator forces f (N, 6) with J^T f = load (N, 6); SingularPoseError at a singular pose."""
    return _solve_transposed(pose.inverse_jacobian, pose.geometry, load)


def _solve_transposed(J: np.ndarray, geometry: RobotGeometry, load: np.ndarray) -> np.ndarray:
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


def gravity_load(geometry: RobotGeometry, ik: InverseKinematicsResult) -> np.ndarray:
    """Q_g (N, 6) [N, N m] in closed form: minus the power of the weights of ring_b and of every
    leg link per unit twist (v, omega) of ring_b (virtual work; eq. 19 at rest).

    The link coms move with the leg: the lower com a_i + c_l u_i, the upper com B_i - c_u u_i,
    where dB_i = v + omega × (A_c s'_i) and du_i = (I - u_i u_i^T) dB_i / L_i. So each leg's
    weight acts on ring_b as a force w_i = m_u g + (m_l c_l - m_u c_u) / L_i (I - u_i u_i^T) g
    at B_i. The same load as ``generalized_forces(pose, 0, 0)`` without the dynamic terms.
    """
    g = geometry.gravity
    u, lengths = ik.unit_vectors, ik.lengths
    lo, up = geometry.lower_link, geometry.upper_link
    g_normal = g - u * np.einsum('...ij,j->...i', u, g)[..., None]
    w = ((lo.mass * lo.com_from_joint - up.mass * up.com_from_joint) / lengths)[..., None] * g_normal \
        + up.mass * g
    r = ik.ring_b_anchors_in_a - ik.position[..., None, :]                    # A_c s'_i
    com = np.einsum('...ij,j->...i', ik.rotation, geometry.ring_b_body.com)
    mass = geometry.ring_b_body.mass
    force = mass * g + w.sum(axis=-2)
    moment = mass * cross(com, g) + cross(r, w).sum(axis=-2)
    return -np.concatenate([force, moment], axis=-1)


def holding_forces(geometry: RobotGeometry, position, quaternion_xyzw) -> np.ndarray:
    """Actuator forces [N] (6,) holding ring_b at rest at a pose against gravity, legs included.

    ``position`` (3,) [m] and ``quaternion_xyzw`` (4,) give a_T_b; batches (N, 3), (N, 4) give
    (N, 6). Raises ValueError for invalid input, SingularPoseError (a ValueError too) for a
    locked universal joint or a singular pose.
    """
    single = np.ndim(position) == 1
    ik, _, _ = assembled_pose(geometry, position, quaternion_xyzw)
    forces = _solve_transposed(inverse_jacobian(ik), geometry, gravity_load(geometry, ik))
    return forces[0] if single else forces
