"""Direct (forward) kinematics on the platform pose by Newton-Raphson (paper section 2.2).

Unknowns: the pose a_T_b. Residual: IK lengths (eq. 1) minus measured lengths. The update is
multiplicative on the rotation, A_c <- exp(Δθ~) A_c, so the quaternion never leaves the unit
sphere. Seeded from a previous pose, it converges quadratically in 2-4 iterations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import RobotGeometry
from .inverse import InverseKinematicsResult, _pose_arrays
from .jacobian import inverse_jacobian
from .rotations import matrix_to_quat_xyzw, quat_xyzw_to_matrix, rotation_vector_to_matrix

__all__ = ['ForwardKinematicsResult', 'forward_kinematics']


@dataclass(frozen=True)
class ForwardKinematicsResult:
    """Pose of ring_b in ring_a (single, or leading N for batches) and how it was found.

    ``converged``: the length residual fell below the tolerance. ``singular``: the Jacobian was
    singular (or ill-conditioned beyond repair) at some iterate. ``residual``: max |l - L| [m].
    """

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    singular: np.ndarray

    @property
    def rotation(self) -> np.ndarray:
        return quat_xyzw_to_matrix(self.quaternion_xyzw)


def forward_kinematics(geometry: RobotGeometry, lengths, seed_position=None,
                       seed_quaternion_xyzw=None, *, tolerance: float = 1e-12,
                       max_iterations: int = 30) -> ForwardKinematicsResult:
    """Newton-Raphson on a_T_b for measured lengths (6,) or (N, 6), seeded by a previous pose.

    Without a seed the home pose is used. Never raises on non-convergence or singularity: the
    result says so. Raises ValueError for NaN/inf or wrongly shaped input.
    """
    L = np.asarray(lengths, dtype=float)
    if L.shape[-1:] != (6,):
        raise ValueError(f'lengths must have shape (6,) or (N, 6), got {L.shape}')
    if not np.all(np.isfinite(L)):
        raise ValueError('lengths contain NaN or infinite values')
    batch = L.shape[:-1]
    if seed_position is None:
        seed_position = np.broadcast_to(geometry.home_position, batch + (3,))
    if seed_quaternion_xyzw is None:
        seed_quaternion_xyzw = np.broadcast_to(geometry.home_quaternion_xyzw, batch + (4,))
    p, q = _pose_arrays(np.broadcast_to(seed_position, batch + (3,)),
                        np.broadcast_to(seed_quaternion_xyzw, batch + (4,)))
    p = p.reshape(-1, 3).copy()
    R = quat_xyzw_to_matrix(q.reshape(-1, 4))
    Lf = L.reshape(-1, 6)
    n = Lf.shape[0]
    active = np.ones(n, dtype=bool)
    converged = np.zeros(n, dtype=bool)
    singular = np.zeros(n, dtype=bool)
    iterations = np.zeros(n, dtype=int)
    residual = np.full(n, np.inf)
    for it in range(max_iterations + 1):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        ik = InverseKinematicsResult(geometry, p[idx], R[idx])
        err = Lf[idx] - ik.lengths
        res = np.max(np.abs(err), axis=1)
        residual[idx] = res
        done = res <= tolerance
        converged[idx[done]] = True
        active[idx[done]] = False
        if it == max_iterations:
            break
        step_idx = idx[~done]
        if step_idx.size == 0:
            break
        J = inverse_jacobian(ik)[~done]
        try:
            dx = np.linalg.solve(J, err[~done][..., None])[..., 0]
            ok = np.all(np.isfinite(dx), axis=1)
        except np.linalg.LinAlgError:
            dx = np.zeros((step_idx.size, 6))
            ok = np.zeros(step_idx.size, dtype=bool)
            for k in range(step_idx.size):
                try:
                    dx[k] = np.linalg.solve(J[k], err[~done][k])
                    ok[k] = np.all(np.isfinite(dx[k]))
                except np.linalg.LinAlgError:
                    pass
        singular[step_idx[~ok]] = True
        active[step_idx[~ok]] = False
        good = step_idx[ok]
        p[good] += dx[ok, :3]
        R[good] = rotation_vector_to_matrix(dx[ok, 3:]) @ R[good]
        iterations[good] += 1
    quat = matrix_to_quat_xyzw(R)
    return ForwardKinematicsResult(
        position=p.reshape(batch + (3,)),
        quaternion_xyzw=quat.reshape(batch + (4,)),
        converged=converged.reshape(batch) if batch else bool(converged[0]),
        iterations=iterations.reshape(batch) if batch else int(iterations[0]),
        residual=residual.reshape(batch) if batch else float(residual[0]),
        singular=singular.reshape(batch) if batch else bool(singular[0]),
    )
