"""Numba kernel of the reachable workspace: every limit of every grid point, in parallel.

The same classification as the NumPy path of :func:`rrps_kinematics.workspace.reachable_workspace`
(``limits.margins(...).ok`` per pose, the first limit broken in the order of
``workspace.LIMIT_KINDS``), built from the single-pose helpers of :mod:`.compiled_limits`. A pose
stops being evaluated at its first broken limit, and a point at its first unreachable orientation,
so the singular values (:func:`inverse_condition`) are paid only by poses within every other limit. The tests
check both paths classify every point alike. Imported lazily.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from rrps_kinematics.compiled import quat_to_matrix
from rrps_kinematics.compiled_limits import scaled_inverse_jacobian, segment_distance, vector_angle
from rrps_kinematics.limits import LIMIT_KINDS

__all__ = ['classify_grid', 'classify_grid_parallel', 'inverse_condition', 'WITHIN_LIMITS']

#: Status of a pose within every limit; a broken limit's status is its index in LIMIT_KINDS.
WITHIN_LIMITS = len(LIMIT_KINDS)
_STROKE, _UNIVERSAL, _SPHERICAL, _INTERFERENCE, _CONDITIONING = (
    LIMIT_KINDS.index(k) for k in ('stroke', 'universal', 'spherical', 'interference', 'conditioning'))


@numba.njit(cache=True, nogil=True, error_model='numpy')
def inverse_condition(J):
    """sigma_min / sigma_max of J (6, 6), 0 when sigma_max is 0, by one-sided Jacobi (Hestenes):
    plane rotations of J's columns until they are orthogonal, the singular values then being
    their norms. Accurate to a few ulps relative even for small singular values, and without
    LAPACK's allocations (``np.linalg.svd`` cost more than every limit before it). Overwrites J."""
    for _ in range(60):
        rotated = False
        for i in range(5):
            for j in range(i + 1, 6):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(6):
                    alpha += J[k, i] * J[k, i]
                    beta += J[k, j] * J[k, j]
                    gamma += J[k, i] * J[k, j]
                if not abs(gamma) > 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for k in range(6):
                    a, b = J[k, i], J[k, j]
                    J[k, i] = c * a - s * b
                    J[k, j] = s * a + c * b
        if not rotated:
            break
    smallest = math.inf
    largest = 0.0
    for i in range(6):
        norm = 0.0
        for k in range(6):
            norm += J[k, i] * J[k, i]
        smallest = min(smallest, norm)
        largest = max(largest, norm)
    return math.sqrt(smallest / largest) if largest > 0.0 else 0.0


@numba.njit(cache=True, nogil=True, error_model='numpy')
def _classify_pose(g, p, q, R, b_in_a, u, lengths, J):  # noqa: C901 - a compiled kernel: flat loops for numba
    """(first limit broken or WITHIN_LIMITS, inverse condition number) of the pose (p, q).

    ``g``: :class:`rrps_kinematics.limits.LimitArrays`; a NaN margin counts as broken.
    """
    A, B, axes_a, axes_b, limits = (g.ring_a_anchors, g.ring_b_anchors, g.ring_a_joint_axes,
                                    g.ring_b_joint_axes, g.limits)
    quat_to_matrix(q, R)
    for i in range(6):  # compiled_limits.pose_in_ring_a, leg by leg: out at the first stroke broken
        s = 0.0
        for k in range(3):
            b_in_a[i, k] = p[k] + R[k, 0] * B[i, 0] + R[k, 1] * B[i, 1] + R[k, 2] * B[i, 2]
            d = b_in_a[i, k] - A[i, k]
            u[i, k] = d
            s += d * d
        lengths[i] = math.sqrt(s)
        if not (lengths[i] - limits[0] >= 0.0 and limits[1] - lengths[i] >= 0.0):
            return _STROKE, math.nan
        for k in range(3):
            u[i, k] /= lengths[i]
    for i in range(6):
        if not (limits[2] - vector_angle(u[i, 0], u[i, 1], u[i, 2],
                                   axes_a[i, 0], axes_a[i, 1], axes_a[i, 2]) >= 0.0):
            return _UNIVERSAL, math.nan
    for i in range(6):
        # the leg from the S-joint towards ring_a in ring_b's frame: -R^T u
        t0 = -(R[0, 0] * u[i, 0] + R[1, 0] * u[i, 1] + R[2, 0] * u[i, 2])
        t1 = -(R[0, 1] * u[i, 0] + R[1, 1] * u[i, 1] + R[2, 1] * u[i, 2])
        t2 = -(R[0, 2] * u[i, 0] + R[1, 2] * u[i, 1] + R[2, 2] * u[i, 2])
        if not (limits[3] - vector_angle(t0, t1, t2, axes_b[i, 0], axes_b[i, 1], axes_b[i, 2]) >= 0.0):
            return _SPHERICAL, math.nan
    for i in range(6):
        for j in range(i + 1, 6):
            if not (segment_distance(A[i], b_in_a[i], A[j], b_in_a[j]) - 2.0 * limits[4] >= 0.0):
                return _INTERFERENCE, math.nan
    scaled_inverse_jacobian(u, b_in_a, p, 1.0 / limits[5], J)
    for i in range(6):
        for k in range(6):
            if not math.isfinite(J[i, k]):
                return _CONDITIONING, math.nan
    inv_cond = inverse_condition(J)
    if not (inv_cond - limits[6] >= 0.0 and inv_cond > 0.0):
        return _CONDITIONING, math.nan
    return WITHIN_LIMITS, inv_cond


@numba.njit(cache=True, nogil=True, error_model='numpy')
def _classify_slice(g, x, ys, zs, Q, status, inverse_condition):
    """The points (x, ys[j], zs[k]) of one grid slice: status and inverse_condition (J, K)."""
    p = np.empty(3)
    R = np.empty((3, 3))
    b_in_a = np.empty((6, 3))
    u = np.empty((6, 3))
    lengths = np.empty(6)
    J = np.empty((6, 6))
    p[0] = x
    for j in range(ys.shape[0]):
        p[1] = ys[j]
        for k in range(zs.shape[0]):
            p[2] = zs[k]
            code = WITHIN_LIMITS
            worst = math.inf
            for n in range(Q.shape[0]):
                code, inv_cond = _classify_pose(g, p, Q[n], R, b_in_a, u, lengths, J)
                if code != WITHIN_LIMITS:
                    break
                worst = min(worst, inv_cond)
            status[j, k] = code
            inverse_condition[j, k] = worst if code == WITHIN_LIMITS else math.nan


@numba.njit(cache=True, nogil=True, error_model='numpy')
def classify_grid(g, xs, ys, zs, Q, status, inverse_condition):
    """Classify the grid positions (xs[i], ys[j], zs[k]) over the orientations Q (K, 4), in place.

    ``status[i, j, k]``: WITHIN_LIMITS when the point is within every limit at every orientation,
    else the first limit broken at its first unreachable orientation. ``inverse_condition``: the
    smallest inverse condition number over the orientations (NaN when not within the limits).
    """
    for i in range(xs.shape[0]):
        _classify_slice(g, xs[i], ys, zs, Q, status[i], inverse_condition[i])


@numba.njit(cache=True, nogil=True, parallel=True, error_model='numpy')
def classify_grid_parallel(g, xs, ys, zs, Q, status, inverse_condition):
    """:func:`classify_grid` on numba's threads, one slice of x per task: the same numbers."""
    for i in numba.prange(xs.shape[0]):
        _classify_slice(g, xs[i], ys, zs, Q, status[i], inverse_condition[i])
