"""Numba kernel of the reachable workspace: every limit of every grid point, in parallel.

The same classification as the NumPy path of :func:`rrps_kinematics.workspace.reachable_workspace`
(``limits.margins(...).ok`` per pose, the first limit broken in the order of
``workspace.LIMIT_KINDS``), built from the single-pose helpers of :mod:`.compiled_limits`. A pose
stops being evaluated at its first broken limit, and a point at its first unreachable orientation,
so the singular value decomposition is paid only by poses within every other limit. The tests
check both paths classify every point alike. Imported lazily.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from rrps_kinematics.compiled_limits import pose_in_ring_a, scaled_inverse_jacobian, segment_distance, vector_angle
from rrps_kinematics.limits import LIMIT_KINDS

__all__ = ['classify_grid', 'WITHIN_LIMITS']

#: Status of a pose within every limit; a broken limit's status is its index in LIMIT_KINDS.
WITHIN_LIMITS = len(LIMIT_KINDS)
_STROKE, _UNIVERSAL, _SPHERICAL, _INTERFERENCE, _CONDITIONING = (
    LIMIT_KINDS.index(k) for k in ('stroke', 'universal', 'spherical', 'interference', 'conditioning'))


@numba.njit(cache=True, nogil=True)
def _classify_pose(g, p, q, R, b_in_a, u, lengths, J):
    """(first limit broken or WITHIN_LIMITS, inverse condition number) of the pose (p, q).

    ``g``: :class:`rrps_kinematics.limits.LimitArrays`; a NaN margin counts as broken.
    """
    A, B, axes_a, axes_b, limits = (g.ring_a_anchors, g.ring_b_anchors, g.ring_a_joint_axes,
                                    g.ring_b_joint_axes, g.limits)
    pose_in_ring_a(A, B, p, q, R, b_in_a, u, lengths)
    for i in range(6):
        if not (lengths[i] - limits[0] >= 0.0 and limits[1] - lengths[i] >= 0.0):
            return _STROKE, math.nan
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
    sv = np.linalg.svd(J)[1]
    inv_cond = sv[5] / sv[0] if sv[0] > 0.0 else 0.0
    if not (inv_cond - limits[6] >= 0.0 and inv_cond > 0.0):
        return _CONDITIONING, math.nan
    return WITHIN_LIMITS, inv_cond


@numba.njit(cache=True, nogil=True)
def classify_grid(g, xs, ys, zs, Q, status, inverse_condition):
    """Classify the grid positions (xs[i], ys[j], zs[k]) over the orientations Q (K, 4), in place.

    ``status[i, j, k]``: WITHIN_LIMITS when the point is within every limit at every orientation,
    else the first limit broken at its first unreachable orientation. ``inverse_condition``: the
    smallest inverse condition number over the orientations (NaN when not within the limits).
    A serial loop: numba's prange measured no faster on the project's shared two-core machines.
    """
    for i in range(xs.shape[0]):
        p = np.empty(3)
        R = np.empty((3, 3))
        b_in_a = np.empty((6, 3))
        u = np.empty((6, 3))
        lengths = np.empty(6)
        J = np.empty((6, 6))
        p[0] = xs[i]
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
                status[i, j, k] = code
                inverse_condition[i, j, k] = worst if code == WITHIN_LIMITS else math.nan
