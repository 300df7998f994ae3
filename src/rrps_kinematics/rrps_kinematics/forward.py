"""Direct (forward) kinematics on the platform pose by Newton-Raphson (§2.2).

Residual: measured minus IK lengths (eq. 1); step J dx = L - l, J the inverse Jacobian
(:mod:`.jacobian`); the rotation is updated multiplicatively, so the quaternion stays unit. Damped
far from a solution (rotation <= pi/2, halved until the residual decreases), so :mod:`.assembly`'s
multi-start uses it too. One kernel (:mod:`.compiled`); a stream goes through :class:`ForwardSolver`.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_kinematics.backend import PARALLEL_BATCH, compiled_backend_available, interpreted, run_parallel, use_numba
from rrps_kinematics.inverse import pose_arrays

__all__ = ['ForwardKinematicsResult', 'ForwardSolver', 'check_lengths', 'forward_kinematics',
           'compiled_backend_available']


class ForwardKinematicsResult(NamedTuple):
    """Pose of ring_b in ring_a (leading N for batches; quaternion w >= 0) and how it was found:
    ``converged`` (``residual``, max |l - L| [m], below the tolerance), ``singular`` (the Jacobian was
    singular at an iterate, where the solve stopped), Newton ``iterations``."""

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    singular: np.ndarray

    @property
    def rotation(self) -> np.ndarray:
        return quat_xyzw_to_matrix(self.quaternion_xyzw)


def check_lengths(lengths, *, batch: bool = True) -> np.ndarray:
    """Actuator lengths L_i (eq. 1) as a contiguous float array: (6,), or with ``batch`` also
    (..., 6). Raises ValueError for another shape or NaN/inf values."""
    L = np.asarray(lengths, dtype=float)
    if batch and L.shape[-1:] != (6,):
        raise ValueError(f'lengths must have shape (6,) or (N, 6), got {L.shape}')
    if not batch and L.shape != (6,):
        raise ValueError(f'lengths must have shape (6,), got {L.shape}')
    if not np.isfinite(L).all():
        raise ValueError('lengths contain NaN or infinite values')
    return np.ascontiguousarray(L)


def _check_limits(tolerance: float, max_iterations: int) -> None:
    if not (tolerance > 0.0 and math.isfinite(tolerance)):
        raise ValueError(f'tolerance must be a positive finite number, got {tolerance!r}')
    if int(max_iterations) != max_iterations or max_iterations < 0:
        raise ValueError(f'max_iterations must be a non-negative integer, got {max_iterations!r}')


def forward_kinematics(geometry: RobotGeometry, lengths, seed_position=None,
                       seed_quaternion_xyzw=None, *, tolerance: float = 1e-12,
                       max_iterations: int = 30, backend: str = 'auto') -> ForwardKinematicsResult:
    """Newton-Raphson on a_T_b for lengths (6,) or (N, 6) from a seed (default home; broadcast).
    Never raises on non-convergence or singularity (the result says so); ValueError for NaN/inf or
    wrongly shaped input. A stream of solves is cheaper through :class:`ForwardSolver`."""
    key = (id(geometry), tolerance, max_iterations, backend)
    entry = _solvers.get(key)
    if entry is None or entry.geometry is not geometry:
        entry = ForwardSolver(geometry, tolerance=tolerance, max_iterations=max_iterations, backend=backend)
        if len(_solvers) >= 64:
            _solvers.clear()
        _solvers[key] = entry
    return entry(lengths, seed_position, seed_quaternion_xyzw)


_ARRAY = np.ndarray
#: The solvers of recent forward_kinematics calls, by geometry object and settings.
_solvers: dict[tuple, 'ForwardSolver'] = {}


class ForwardSolver:
    """Forward kinematics of one robot with fixed settings, checked once, for a stream of solves:
    ``solver(lengths, seed_position, seed_quaternion_xyzw)`` is :func:`forward_kinematics`. Float
    arrays go straight to the kernel, which checks them; what it refuses, Python checks and raises."""

    def __init__(self, geometry: RobotGeometry, *, tolerance: float = 1e-12, max_iterations: int = 30,
                 backend: str = 'auto'):
        _check_limits(tolerance, max_iterations)
        self.geometry = geometry
        self.tolerance = float(tolerance)
        self.max_iterations = int(max_iterations)
        self.numba = use_numba(backend)
        self._A, self._B = (np.array(a, dtype=float, order='C') for a in (geometry.ring_a_anchors,
                                                                           geometry.ring_b_anchors))
        if not self.numba:  # interpreted: rows of Python floats
            self._A, self._B = self._A.tolist(), self._B.tolist()
        self._inv_scale = 1.0 / geometry.characteristic_length
        self._kernels = _kernels()
        self._kernel = self._kernels.fk_solve if self.numba else None

    @cached_property
    def _home(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array(self.geometry.home_position, dtype=float),
                np.array(self.geometry.home_quaternion_xyzw, dtype=float))

    def __call__(self, lengths, seed_position=None, seed_quaternion_xyzw=None) -> ForwardKinematicsResult:
        p = self._home[0] if seed_position is None else seed_position
        q = self._home[1] if seed_quaternion_xyzw is None else seed_quaternion_xyzw
        if self._kernel is not None and type(lengths) is _ARRAY and type(p) is _ARRAY and type(q) is _ARRAY:
            try:
                ok, p2, q2, c, it, res, sing = self._kernel(self._A, self._B, lengths, p, q, self._inv_scale,
                                                            self.tolerance, self.max_iterations)
            except TypeError:  # not writable C-contiguous float64 vectors
                ok = False
            if ok:
                return ForwardKinematicsResult(p2, q2, c, it, res, sing)
        return self._solve(check_lengths(lengths), p, q)

    def _solve(self, L, seed_p, seed_q) -> ForwardKinematicsResult:
        batch = L.shape[:-1]
        seed_p = np.asarray(seed_p, dtype=float)
        seed_q = np.asarray(seed_q, dtype=float)
        if not batch and seed_p.shape == (3,) and seed_q.shape == (4,):
            return self._single(L, *pose_arrays(seed_p, seed_q))
        try:
            seed_p = np.broadcast_to(seed_p, batch + (3,))
            seed_q = np.broadcast_to(seed_q, batch + (4,))
        except ValueError:
            raise ValueError(f'seed shapes {seed_p.shape}, {seed_q.shape} do not match lengths '
                             f'{L.shape}') from None
        p, q = pose_arrays(seed_p, seed_q)
        P = np.array(p.reshape(-1, 3), dtype=float, order='C')
        Q = np.ascontiguousarray(q.reshape(-1, 4))  # pose_arrays' normalised copy: the kernel solves in it
        Lf = np.ascontiguousarray(L.reshape(-1, 6))
        solve = _batch_numba if self.numba else _batch_interpreted
        P, Q, converged, iterations, residual, singular = solve(
            self._A, self._B, Lf, P, Q, self._inv_scale, self.tolerance, self.max_iterations)
        return ForwardKinematicsResult(P.reshape(batch + (3,)), Q.reshape(batch + (4,)),
                                       converged.reshape(batch), iterations.reshape(batch),
                                       residual.reshape(batch), singular.reshape(batch))

    def _single(self, L, p, q) -> ForwardKinematicsResult:
        """A single solve of checked input (p, unit q)."""
        if self.numba:
            _, p, q, c, it, res, sing = self._kernels.fk_solve(
                self._A, self._B, np.array(L), np.array(p), np.array(q), self._inv_scale, self.tolerance,
                self.max_iterations)
            return ForwardKinematicsResult(p, q, c, it, res, sing)
        p, q = p.tolist(), q.tolist()
        c, it, res, sing = interpreted(self._kernels.fk_single)(self._A, self._B, L.tolist(), p, q, self._inv_scale,
                                                           self.tolerance, self.max_iterations)
        q = np.array(q)
        return ForwardKinematicsResult(np.array(p), -q if q[3] < 0.0 else q, c, it, res, sing)


def _batch_interpreted(A, B, L, P, Q, inv_scale, tolerance, max_iterations):
    """The batch kernel interpreted, on lists: (P, Q, converged, iterations, residual, singular)."""
    n = L.shape[0]
    P, Q = P.tolist(), Q.tolist()
    converged, iterations, residual, singular = [False] * n, [0] * n, [0.0] * n, [False] * n
    interpreted(_kernels().fk_batch)(A, B, L.tolist(), P, Q, inv_scale, tolerance, max_iterations, converged,
                                   iterations, residual, singular)
    return (np.array(P, dtype=float).reshape(n, 3), np.array(Q, dtype=float).reshape(n, 4),
            np.array(converged, dtype=np.bool_), np.array(iterations, dtype=np.int64),
            np.array(residual, dtype=float), np.array(singular, dtype=np.bool_))


def _batch_numba(A, B, L, P, Q, inv_scale, tolerance, max_iterations):
    """The compiled batch, in place on P, Q: on every thread when long enough and no other
    thread runs a parallel kernel, else serially (the same numbers either way)."""
    n = L.shape[0]
    converged = np.empty(n, dtype=np.bool_)  # the kernel writes every row of these
    iterations = np.empty(n, dtype=np.int64)
    residual = np.empty(n)
    singular = np.empty(n, dtype=np.bool_)
    args = (A, B, L, P, Q, inv_scale, tolerance, max_iterations, converged, iterations, residual, singular)
    kernels = _kernels()
    if not (n >= PARALLEL_BATCH and run_parallel(kernels.fk_batch_parallel, *args)):
        kernels.fk_batch(*args)
    return P, Q, converged, iterations, residual, singular


def _kernels():
    """The FK kernels (:mod:`.compiled`), imported on first use (numba compiles or loads them)."""
    from rrps_kinematics import compiled
    return compiled
