"""Multibody model of an RRPS platform on 91 coordinates (§2.2, eqs. 2-12).

13 bodies (ring_a is ground: 0 ring_b, 1 + 2k and 2 + 2k leg k's lower and upper link), each with
q_b = [r_b, p_b] (centre of mass in ring_a's frame, Euler parameters) at q[7b:7b+7]; constraints
Φ = [Φ^K (72); Φ^D (6); Φ^P (13)] (eq. 2) from :mod:`.multibody_constraints`, every row in
docs/robot-model.md, 'The multibody model'. Newton's solve (eq. 11) is :func:`structured_solve` by
default, SuperLU on the sparse analytic Φ_q or dense LAPACK otherwise.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import (
    euler_parameters_to_quat_xyzw,
    matrix_to_euler_parameters,
    normalize_quat,
    quat_xyzw_to_euler_parameters,
    quat_xyzw_to_matrix,
)
from rrps_kinematics.backend import jit
from rrps_kinematics.errors import SingularPoseError
from rrps_kinematics.forward import check_lengths
from rrps_kinematics.inverse import inverse_kinematics, pose_arrays, universal_joint_frames
from rrps_kinematics.multibody_constraints import (
    FLOPS_LEG_JACOBIAN,
    FLOPS_LEG_RESIDUAL,
    FLOPS_NORMALISATION,
    FLOPS_ROTATION,
    N_BODIES,
    N_CONSTRAINTS,
    N_COORDINATES,
    N_DRIVING,
    N_JOINT_CONSTRAINTS,
    JointGeometry,
    all_constraints,
    all_jacobian,
    body_slice,
    leg_jacobian,
    leg_residual,
    leg_residual_with_rotations,
    lower_link_body,
    rotation,
    rotation_into,
    upper_link_body,
)

__all__ = [
    'FLOPS_LEG_JACOBIAN',
    'FLOPS_LEG_RESIDUAL',
    'FLOPS_ROTATION',
    'N_BODIES',
    'N_CONSTRAINTS',
    'N_COORDINATES',
    'N_DRIVING',
    'N_JOINT_CONSTRAINTS',
    'JointGeometry',
    'MultibodyModel',
    'MultibodyDKResult',
    'body_slice',
    'gauss_eliminate',
    'leg_jacobian',
    'leg_residual',
    'leg_residual_with_rotations',
    'lower_link_body',
    'rotation',
    'rotation_into',
    'structured_solve',
    'upper_link_body',
]

@jit
def gauss_eliminate(A, nrow, ncol_pivot, ncol):
    """Gaussian elimination with partial pivoting of A[:nrow, :ncol] on its first ncol_pivot
    columns (in place); returns (ok, flops)."""
    flops = 0
    for j in range(ncol_pivot):
        p = j
        big = abs(A[j, j])
        for i in range(j + 1, nrow):
            if abs(A[i, j]) > big:
                big = abs(A[i, j])
                p = i
        if big == 0.0:
            return False, flops
        if p != j:
            for m in range(ncol):
                tmp = A[j, m]
                A[j, m] = A[p, m]
                A[p, m] = tmp
        inv = 1.0 / A[j, j]
        flops += 1
        for i in range(j + 1, nrow):
            f = A[i, j] * inv
            A[i, j] = 0.0
            if f != 0.0:
                for m in range(j + 1, ncol):
                    A[i, m] -= f * A[j, m]
                flops += 1 + 2 * (ncol - j - 1)
    return True, flops


@jit
def structured_solve(J, rhs):  # noqa: C901 - a compiled kernel: flat loops for numba
    """Solve Φ_q Δq = rhs (91) by the robot's structure; returns (ok, Δq, flops counted).

    Each leg's 15 rows touch only its 14 link coordinates and ring_b's 7: eliminating the link unknowns
    (partial pivoting) leaves, with ring_b's normalisation, a 7 x 7 system; back-substitution the rest."""
    dq = np.zeros(91)
    U = np.empty((6, 15, 22))
    S = np.empty((7, 8))
    flops = 0
    for k in range(6):
        c0 = 7 * (1 + 2 * k)
        rows = np.empty(15, dtype=np.int64)
        for i in range(12):
            rows[i] = 12 * k + i
        rows[12] = 72 + k
        rows[13] = 78 + 1 + 2 * k
        rows[14] = 78 + 2 + 2 * k
        for i in range(15):
            r = rows[i]
            for j in range(14):
                U[k, i, j] = J[r, c0 + j]
            for j in range(7):
                U[k, i, 14 + j] = J[r, j]
            U[k, i, 21] = rhs[r]
        ok, f = gauss_eliminate(U[k], 15, 14, 22)
        flops += f
        if not ok:
            return False, dq, flops
        for j in range(8):
            S[k, j] = U[k, 14, 14 + j]
    for j in range(7):
        S[6, j] = J[78, j]
    S[6, 7] = rhs[78]
    ok, f = gauss_eliminate(S, 7, 7, 8)
    flops += f
    if not ok:
        return False, dq, flops
    for i in range(6, -1, -1):
        s = S[i, 7]
        for m in range(i + 1, 7):
            s -= S[i, m] * dq[m]
        dq[i] = s / S[i, i]
        flops += 2 * (6 - i) + 1
    for k in range(6):
        c0 = 7 * (1 + 2 * k)
        for i in range(13, -1, -1):
            s = U[k, i, 21]
            for m in range(7):
                s -= U[k, i, 14 + m] * dq[m]
            for m in range(i + 1, 14):
                s -= U[k, i, m] * dq[c0 + m]
            dq[c0 + i] = s / U[k, i, i]
            flops += 2 * 7 + 2 * (13 - i) + 1
    return True, dq, flops


# --- the model ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class MultibodyDKResult:
    """Direct kinematics on the 91 coordinates (eqs. 11-12).

    ``q`` the solution, ``position``/``quaternion_xyzw`` ring_b's pose a_T_b extracted from it,
    ``residual`` max |Φ| at the end, ``iterations`` Newton steps taken, ``flops`` the operation
    count of :meth:`MultibodyModel.direct_kinematics`'s flop model, ``seconds`` wall time.
    """

    q: np.ndarray
    position: np.ndarray
    quaternion_xyzw: np.ndarray
    converged: bool
    iterations: int
    residual: float
    flops: int
    seconds: float


class MultibodyModel:
    """The 13-body, 91-coordinate model of one robot (see the module docstring)."""

    def __init__(self, geometry: RobotGeometry):
        self.geometry = geometry
        self.ring_b_com = np.asarray(geometry.ring_b_body.com, dtype=float)
        self.joints = JointGeometry(
            a=np.ascontiguousarray(geometry.ring_a_anchors, dtype=float),
            ha=np.ascontiguousarray(universal_joint_frames(geometry)[:, :, 0]),
            sb=np.ascontiguousarray(geometry.ring_b_anchors - self.ring_b_com),
            cl=float(geometry.lower_link.com_from_joint),
            cu=float(geometry.upper_link.com_from_joint))

    @cached_property
    def _sparsity(self) -> scipy.sparse.csc_matrix:
        """Structural nonzeros of Φ_q: every entry a kernel writes, at home and a generic pose
        (found on first use: only the sparse Jacobian and solver need them)."""
        pattern = all_jacobian(self.coordinates_from_pose(self.geometry.home_position,
                                                          self.geometry.home_quaternion_xyzw),
                               self.joints)
        q_rand = np.random.default_rng(0).normal(size=91)
        mask = (pattern != 0) | (all_jacobian(q_rand, self.joints) != 0)
        return scipy.sparse.csc_matrix(mask.astype(float))

    @cached_property
    def _entries(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the structural nonzeros, in CSC order."""
        return (self._sparsity.indices.copy(),
                np.repeat(np.arange(91), np.diff(self._sparsity.indptr)))

    # --- coordinates <-> pose ---

    def coordinates_from_pose(self, position, quaternion_xyzw) -> np.ndarray:
        """Consistent q (91,) for ring_b at a_T_b: every joint constraint satisfied exactly."""
        p, quat = pose_arrays(position, quaternion_xyzw)
        if p.ndim != 1:
            raise ValueError('coordinates_from_pose takes a single pose')
        quat = normalize_quat(quat)
        ik = inverse_kinematics(self.geometry, p, quat)
        if np.any(ik.lengths < 1e-9):
            raise SingularPoseError('singular pose: a leg has zero length')
        q = np.empty(91)
        Rb = quat_xyzw_to_matrix(quat)
        q[0:3] = p + Rb @ self.ring_b_com
        q[3:7] = quat_xyzw_to_euler_parameters(quat)
        p_links = matrix_to_euler_parameters(ik.lower_link_rotations)
        u = ik.unit_vectors
        for k in range(6):
            ol, ou = 7 * lower_link_body(k), 7 * upper_link_body(k)
            q[ol:ol + 3] = self.joints.a[k] + self.joints.cl * u[k]
            q[ol + 3:ol + 7] = p_links[k]
            q[ou:ou + 3] = ik.ring_b_anchors_in_a[k] - self.joints.cu * u[k]
            q[ou + 3:ou + 7] = p_links[k]
        return q

    def pose_from_coordinates(self, q) -> tuple[np.ndarray, np.ndarray]:
        """ring_b's (position, quaternion_xyzw) in ring_a's frame from q."""
        q = self._check_q(q)
        quat = normalize_quat(euler_parameters_to_quat_xyzw(q[3:7]))
        return q[0:3] - quat_xyzw_to_matrix(quat) @ self.ring_b_com, quat

    def lengths(self, q) -> np.ndarray:
        """Actuator lengths h_l^T d (eq. 10 without C) of q."""
        return self.constraints(q, np.zeros(6))[72:78]

    # --- constraints and Jacobian ---

    def constraints(self, q, lengths) -> np.ndarray:
        """Φ(q) of eq. 2, shape (91,); lengths (6,) enter the driving constraints."""
        q = self._check_q(q)
        L = check_lengths(lengths, batch=False)
        return all_constraints(q, L, self.joints)

    def jacobian(self, q, *, sparse: bool = False):
        """Analytic Φ_q (91 x 91), dense ndarray or scipy.sparse CSC (structural nonzeros)."""
        q = self._check_q(q)
        J = all_jacobian(q, self.joints)
        if not sparse:
            return J
        return scipy.sparse.csc_matrix((J[self._entries], self._sparsity.indices,
                                        self._sparsity.indptr), shape=(91, 91))

    @property
    def jacobian_nonzeros(self) -> int:
        """Structural nonzeros of Φ_q."""
        return int(self._sparsity.nnz)

    # --- direct kinematics ---

    def direct_kinematics(self, lengths, q_seed=None, *, tolerance: float = 1e-12,
                          max_iterations: int = 30, solver: str = 'structured') -> MultibodyDKResult:
        """Newton-Raphson Φ_q Δq = -Φ, q <- q + Δq (eqs. 11-12) from a seed (default: home), with
        ``solver`` 'structured', 'sparse' or 'dense'; the result's flop model is in docs/measurements.md
        ('Dynamics'). Never raises on non-convergence; the result says so."""
        if solver not in ('structured', 'sparse', 'dense'):
            raise ValueError(f"solver must be 'structured', 'sparse' or 'dense', got {solver!r}")
        L = check_lengths(lengths, batch=False)
        if q_seed is None:
            q_seed = self.coordinates_from_pose(self.geometry.home_position,
                                                self.geometry.home_quaternion_xyzw)
        q = self._check_q(q_seed).copy()
        t0 = time.perf_counter()
        residual_flops = 6 * FLOPS_LEG_RESIDUAL + 13 * FLOPS_NORMALISATION
        jacobian_flops = 6 * FLOPS_LEG_JACOBIAN + 13 * 4
        n = 91
        flops = 0
        iterations = 0
        converged = False
        phi = all_constraints(q, L, self.joints)
        flops += residual_flops
        res = float(np.max(np.abs(phi)))
        while True:
            if res <= tolerance:
                converged = True
                break
            if iterations >= max_iterations or not np.isfinite(res):
                break
            J = all_jacobian(q, self.joints)
            flops += jacobian_flops
            try:
                if solver == 'structured':
                    ok, dq, solve_flops = structured_solve(J, -phi)
                    if not ok:
                        break
                    flops += solve_flops
                elif solver == 'dense':
                    dq = np.linalg.solve(J, -phi)
                    flops += (2 * n**3) // 3 + 2 * n**2
                else:
                    Js = scipy.sparse.csc_matrix((J[self._entries],
                                                  self._sparsity.indices, self._sparsity.indptr),
                                                 shape=(n, n))
                    lu = scipy.sparse.linalg.splu(Js, permc_spec='COLAMD')
                    dq = lu.solve(-phi)
                    flops += _sparse_lu_flops(lu)
            except (np.linalg.LinAlgError, RuntimeError):
                break
            q += dq
            flops += n
            iterations += 1
            phi = all_constraints(q, L, self.joints)
            flops += residual_flops
            res = float(np.max(np.abs(phi)))
        seconds = time.perf_counter() - t0
        position, quat = self.pose_from_coordinates(q)
        return MultibodyDKResult(q=q, position=position, quaternion_xyzw=quat,
                                 converged=converged, iterations=iterations, residual=res,
                                 flops=int(flops), seconds=seconds)

    def _check_q(self, q) -> np.ndarray:
        q = np.ascontiguousarray(q, dtype=float)
        if q.shape != (91,):
            raise ValueError(f'q must have shape (91,), got {q.shape}')
        if not np.all(np.isfinite(q)):
            raise ValueError('q contains NaN or infinite values')
        return q


_LU_FLOPS_CACHE: dict[tuple, int] = {}


def _sparse_lu_flops(lu) -> int:
    """Right-looking LU work Σ_k (l_k + 2 l_k u_k) + triangular solves 2 (nnz(L) + nnz(U))."""
    Lf = lu.L.tocsc()
    Uf = lu.U.tocsr()
    key = (Lf.nnz, Uf.nnz, Lf.indptr.tobytes(), Uf.indptr.tobytes())
    if key not in _LU_FLOPS_CACHE:
        l_k = np.diff(Lf.indptr) - 1          # L has a unit diagonal stored
        u_k = np.diff(Uf.indptr) - 1
        _LU_FLOPS_CACHE[key] = int(np.sum(l_k + 2 * l_k * u_k) + 2 * (Lf.nnz + Uf.nnz))
    return _LU_FLOPS_CACHE[key]
