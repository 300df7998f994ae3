"""The kernel of the reachable workspace: every limit of every grid point, in parallel.

``limits.margins(...).ok`` per pose and the first limit broken in ``workspace.LIMIT_KINDS`` order; a
pose stops at its first broken limit, a point at its first unreachable orientation."""

from __future__ import annotations

import math

from rrps_kinematics.backend import floats, jit, matrix, parallel_range
from rrps_kinematics.compiled import quat_to_matrix, quotient
from rrps_kinematics.compiled_limits import (
    inverse_condition,
    scaled_inverse_jacobian,
    segment_distance,
    spherical_angle,
    universal_angle,
)
from rrps_kinematics.limits import LIMIT_KINDS

__all__ = ['classify_grid', 'classify_grid_parallel', 'inverse_condition', 'WITHIN_LIMITS']

_OPTIONS = dict(nogil=True, error_model='numpy')
prange = parallel_range()
#: Status of a pose within every limit; a broken limit's status is its index in LIMIT_KINDS.
WITHIN_LIMITS = len(LIMIT_KINDS)
_STROKE, _UNIVERSAL, _SPHERICAL, _INTERFERENCE, _CONDITIONING = (
    LIMIT_KINDS.index(k) for k in ('stroke', 'universal', 'spherical', 'interference', 'conditioning'))


@jit(**_OPTIONS)
def _classify_pose(g, p, q, R, b_in_a, u, lengths, J):  # noqa: C901 - a compiled kernel: flat loops for numba
    """(first limit broken or WITHIN_LIMITS, inverse condition number) of the pose (p, q).

    ``g``: :class:`rrps_kinematics.limits.LimitArrays`; a NaN margin counts as broken.
    """
    A, B, limits = g.ring_a_anchors, g.ring_b_anchors, g.limits
    quat_to_matrix(q, R)
    for i in range(6):  # compiled_limits.pose_in_ring_a, leg by leg: out at the first stroke broken
        a, b, c, ui = A[i], B[i], b_in_a[i], u[i]
        s = 0.0
        for k in range(3):
            c[k] = p[k] + R[3 * k] * b[0] + R[3 * k + 1] * b[1] + R[3 * k + 2] * b[2]
            d = c[k] - a[k]
            ui[k] = d
            s += d * d
        lengths[i] = math.sqrt(s)
        if not (lengths[i] - limits[0] >= 0.0 and limits[1] - lengths[i] >= 0.0):
            return _STROKE, math.nan
        for k in range(3):
            ui[k] = quotient(ui[k], lengths[i])
    for i in range(6):
        if not (limits[2] - universal_angle(u, g.ring_a_joint_axes, i) >= 0.0):
            return _UNIVERSAL, math.nan
    for i in range(6):
        if not (limits[3] - spherical_angle(u, R, g.ring_b_joint_axes, i) >= 0.0):
            return _SPHERICAL, math.nan
    for i in range(6):
        for j in range(i + 1, 6):
            if not (segment_distance(A[i], b_in_a[i], A[j], b_in_a[j]) - 2.0 * limits[4] >= 0.0):
                return _INTERFERENCE, math.nan
    scaled_inverse_jacobian(u, b_in_a, p, 1.0 / limits[5], J)
    inv_cond = inverse_condition(J)
    if not (inv_cond - limits[6] >= 0.0 and inv_cond > 0.0):
        return _CONDITIONING, math.nan
    return WITHIN_LIMITS, inv_cond


@jit(**_OPTIONS)
def _classify_slice(g, x, ys, zs, Q, status, conditions):
    """The points (x, ys[j], zs[k]) of one grid slice: status and conditions (J, K)."""
    p = floats(3)
    R = floats(9)
    b_in_a = matrix(6, 3)
    u = matrix(6, 3)
    lengths = floats(6)
    J = matrix(6, 6)
    p[0] = x
    for j in range(len(ys)):
        p[1] = ys[j]
        status_row, conditions_row = status[j], conditions[j]
        for k in range(len(zs)):
            p[2] = zs[k]
            code = WITHIN_LIMITS
            worst = math.inf
            for n in range(len(Q)):
                code, inv_cond = _classify_pose(g, p, Q[n], R, b_in_a, u, lengths, J)
                if code != WITHIN_LIMITS:
                    break
                worst = min(worst, inv_cond)
            status_row[k] = code
            conditions_row[k] = worst if code == WITHIN_LIMITS else math.nan


@jit(**_OPTIONS)
def classify_grid(g, xs, ys, zs, Q, status, conditions):
    """Classify the grid positions (xs[i], ys[j], zs[k]) over the orientations Q (K, 4), in place.

    ``status[i][j][k]``: WITHIN_LIMITS when the point is within every limit at every orientation,
    else the first limit broken at its first unreachable orientation. ``conditions``: the
    smallest inverse condition number over the orientations (NaN when not within the limits).
    """
    for i in range(len(xs)):
        _classify_slice(g, xs[i], ys, zs, Q, status[i], conditions[i])


@jit(parallel=True, **_OPTIONS)
def classify_grid_parallel(g, xs, ys, zs, Q, status, conditions):
    """:func:`classify_grid` on numba's threads, one slice of x per task: the same numbers
    (compiled only)."""
    for i in prange(xs.shape[0]):
        _classify_slice(g, xs[i], ys, zs, Q, status[i], conditions[i])
