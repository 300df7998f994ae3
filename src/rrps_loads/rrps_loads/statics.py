"""Statics of an RRPS robot at rest on either ring (eq. 19 at rest), by virtual work (J of eq. 1)::

    ring_a supports:  J^T f = -W_b        ring_b supports:  J^T f = W_a

W: the wrench (about ring_b's origin, ring_a's frame) of what the free ring carries; a leg's weight
goes w_i = m_u g + k g⊥ to its spherical joint and m_l g - k g⊥ to its universal joint,
k = (m_l c_l - m_u c_u) / L (g⊥: normal to the leg). Gravity is the world's
(:mod:`rrps_loads.support`); forces push the rings apart when positive. Kernels:
:mod:`rrps_loads.compiled_statics`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.backend import kernels_of, use_numba
from rrps_kinematics.errors import SingularPoseError
from rrps_kinematics.inverse import InverseKinematicsResult
from rrps_loads import compiled_statics
from rrps_loads.reduced import PlatformPose, assembled_pose
from rrps_loads.support import Support, support_of

__all__ = ['RestStatics', 'rest_statics', 'static_load', 'holding_forces', 'solve_actuator_forces',
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


class RestStatics(NamedTuple):
    """The statics kernel at N poses: ``forces`` (N, 6) [N], the reactions on the legs at the
    ``universal`` and ``spherical`` joints (N, 6, 3) [N] and the structure's ``wrench`` on the
    supporting ring (N, 6), in the supporting ring's frame; the ``load`` Q of J^T f = Q (N, 6)
    (ring_a's frame, about ring_b's origin); the holding ``margin`` (N,) (NaN without a capacity)."""

    forces: np.ndarray
    universal: np.ndarray
    spherical: np.ndarray
    wrench: np.ndarray
    load: np.ndarray
    margin: np.ndarray


def rest_statics(geometry: RobotGeometry, support: Support, ik: InverseKinematicsResult, *,
                 backend: str = 'auto') -> RestStatics:
    """The robot at rest on ``support`` at the poses of ``ik`` (N of them), by
    :func:`rrps_loads.compiled_statics.statics_batch`; SingularPoseError at a singular pose."""
    s = compiled_statics.statics_arrays(geometry, support)
    P = np.ascontiguousarray(np.reshape(ik.position, (-1, 3)), dtype=float)
    R = np.ascontiguousarray(np.reshape(ik.rotation, (-1, 9)), dtype=float)
    n = len(P)
    shapes = ((n, 6), (n, 6, 3), (n, 6, 3), (n, 6), (n, 6), (n,))
    if use_numba(backend):
        out = [np.empty(shape) for shape in shapes]
        compiled_statics.statics_batch(s, P, R, *out)
    else:
        out = [np.zeros(shape).tolist() for shape in shapes]
        kernels_of(compiled_statics, backend).statics_batch(type(s)(*(a.tolist() for a in s)), P.tolist(),
                                                            R.tolist(), *out)
        out = [np.array(o, dtype=float).reshape(shape) for o, shape in zip(out, shapes)]
    result = RestStatics(*out)
    bad = np.flatnonzero(~np.all(np.isfinite(result.forces), axis=1))
    if bad.size:
        raise SingularPoseError(f'singular pose (sample {int(bad[0])}): no finite actuator forces hold it')
    return result


def static_load(geometry: RobotGeometry, ik: InverseKinematicsResult, support: Support) -> np.ndarray:
    """The load Q (N, 6) [N, N m] with J^T f = Q at rest (module docstring) on ``support``, at the
    poses of ``ik``."""
    return rest_statics(geometry, support, ik).load


def holding_forces(geometry: RobotGeometry, position, quaternion_xyzw, *, support='ring_a',
                   world_q_support=None, gravity=None) -> np.ndarray:
    """Actuator forces [N] (6,) holding the robot at rest at a_T_b, legs included; batches give (N, 6).
    ``support`` turned by ``world_q_support`` (x, y, z, w). Raises ValueError, SingularPoseError."""
    world = support_of(support, world_q_support, gravity)
    single = np.ndim(position) == 1
    ik, _, _ = assembled_pose(geometry, position, quaternion_xyzw)
    forces = rest_statics(geometry, world, ik).forces
    return forces[0] if single else forces
