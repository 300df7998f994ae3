"""Statics of an RRPS platform: actuator forces that hold a pose against gravity (paper eq. 19
at rest), by virtual work on the reduced model of :mod:`rrps_sim.reduced`.

At rest eq. 19 leaves J^T f = Q_g, with Q_g the generalized load of gravity on ring_b and on
every leg link (component k: the power of -m g on each body for the unit twist e_k of ring_b).
Forces are positive when they push the rings apart.
"""

from __future__ import annotations

import numpy as np

from rrps_kinematics.geometry import RobotGeometry

from .reduced import PlatformPose, generalized_forces

__all__ = ['holding_forces', 'solve_actuator_forces', 'SINGULAR_CONDITIONING']

# Inverse condition number of the unit-consistent Jacobian below which a pose counts as singular.
SINGULAR_CONDITIONING = 1e-9


def solve_actuator_forces(pose: PlatformPose, load: np.ndarray) -> np.ndarray:
    """Actuator forces f (N, 6) with J^T f = load (N, 6); ValueError at a singular pose.

    Singularity is judged on the unit-consistent Jacobian (angular columns divided by the
    robot's characteristic length), so the threshold does not depend on the robot's size.
    """
    J = pose.inverse_jacobian
    scale = np.concatenate([np.ones(3), np.full(3, 1.0 / pose.geometry.characteristic_length)])
    s = np.linalg.svd(J * scale, compute_uv=False)
    conditioning = s[:, -1] / s[:, 0]
    bad = np.flatnonzero(~(conditioning > SINGULAR_CONDITIONING))
    if bad.size:
        raise ValueError(f'singular pose (sample {int(bad[0])}: inverse condition number '
                         f'{conditioning[bad[0]]:.3g}): no finite actuator forces hold it')
    return np.linalg.solve(np.swapaxes(J, -1, -2), np.asarray(load, dtype=float)[..., None])[..., 0]


def holding_forces(geometry: RobotGeometry, position, quaternion_xyzw) -> np.ndarray:
    """Actuator forces [N] (6,) holding ring_b at rest at a pose against gravity, legs included.

    ``position`` (3,) [m] and ``quaternion_xyzw`` (4,) give a_T_b; batches (N, 3), (N, 4) give
    (N, 6). Raises ValueError for invalid input, a locked universal joint or a singular pose.
    """
    single = np.ndim(position) == 1
    pose = PlatformPose(geometry, position, quaternion_xyzw)
    zero = np.zeros((pose.position.shape[0], 6))
    forces = solve_actuator_forces(pose, generalized_forces(pose, zero, zero))
    return forces[0] if single else forces
