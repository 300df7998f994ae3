"""The kernels of a pose's limits (:mod:`.limits`), written once: every signed margin, det J.

Batch and single pose (the IK node, :mod:`.compiled_workspace`, the teleop guards); ``g`` is a ``LimitArrays``."""

from __future__ import annotations

import math

import numpy as np

from rrps_kinematics.backend import floats, jit, matrix
from rrps_kinematics.compiled import quat_to_matrix, quotient

__all__ = ['pose_margins', 'pose_margin_arrays', 'margins_batch', 'segment_distances_batch',
           'jacobian_determinant', 'N_MARGINS', 'pose_in_ring_a', 'vector_angle', 'universal_angle',
           'spherical_angle', 'segment_distance', 'scaled_inverse_jacobian', 'inverse_condition', 'PAIR_COUNT']

_OPTIONS = dict(nogil=True, error_model='numpy')
#: Layout of :func:`pose_margins`' output: min stroke, universal, spherical, interference
#: margins, conditioning margin, inverse condition number.
N_MARGINS = 6
#: Leg pairs, in the order of ``limits.PAIRS`` (i < j, i the slower index).
PAIR_COUNT = 15


@jit(**_OPTIONS)
def pose_in_ring_a(A, B, p, R, b_in_a, u, lengths):
    """Ring_b's anchors in ring_a's frame, unit leg vectors and lengths (eq. 1) for the rotation R (9,)."""
    for i in range(6):
        a, b, c, ui = A[i], B[i], b_in_a[i], u[i]
        s = 0.0
        for k in range(3):
            c[k] = p[k] + R[3 * k] * b[0] + R[3 * k + 1] * b[1] + R[3 * k + 2] * b[2]
            d = c[k] - a[k]
            ui[k] = d
            s += d * d
        lengths[i] = math.sqrt(s)
        for k in range(3):
            ui[k] = quotient(ui[k], lengths[i])


@jit(**_OPTIONS)
def vector_angle(u0, u1, u2, v0, v1, v2):
    """Angle between unit vectors: atan2(|u x v|, u . v)."""
    c0 = u1 * v2 - u2 * v1
    c1 = u2 * v0 - u0 * v2
    c2 = u0 * v1 - u1 * v0
    return math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), u0 * v0 + u1 * v1 + u2 * v2)


@jit(**_OPTIONS)
def universal_angle(u, axes_a, i):
    """Leg i's angle from its universal joint's neutral axis (ring_a)."""
    ui, a = u[i], axes_a[i]
    return vector_angle(ui[0], ui[1], ui[2], a[0], a[1], a[2])


@jit(**_OPTIONS)
def spherical_angle(u, R, axes_b, i):
    """Leg i seen from ring_b (towards ring_a, -R^T u): its angle from its spherical joint's
    neutral axis."""
    ui, b = u[i], axes_b[i]
    t0 = -(R[0] * ui[0] + R[3] * ui[1] + R[6] * ui[2])
    t1 = -(R[1] * ui[0] + R[4] * ui[1] + R[7] * ui[2])
    t2 = -(R[2] * ui[0] + R[5] * ui[1] + R[8] * ui[2])
    return vector_angle(t0, t1, t2, b[0], b[1], b[2])


@jit(**_OPTIONS)
def _clip01(x):
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@jit(**_OPTIONS)
def segment_distance(p0, p1, q0, q1):
    """Closest distance of segments p0->p1 and q0->q1: the clamped closest-point problem in closed
    form (Ericson, Real-Time Collision Detection, 5.1.9), degenerate and parallel segments included."""
    d10, d11, d12 = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d20, d21, d22 = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    r0, r1, r2 = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d10 * d10 + d11 * d11 + d12 * d12
    e = d20 * d20 + d21 * d21 + d22 * d22
    b = d10 * d20 + d11 * d21 + d12 * d22
    c = d10 * r0 + d11 * r1 + d12 * r2
    f = d20 * r0 + d21 * r1 + d22 * r2
    tiny = 1e-30
    a_pt = a <= tiny  # p is a point
    e_pt = e <= tiny  # q is a point
    a_safe = 1.0 if a_pt else a
    e_safe = 1.0 if e_pt else e
    denom = a * e - b * b
    parallel = denom <= 1e-12 * a * e
    # closest point of the infinite lines, s clamped, then t, then s re-clamped
    s = 0.0 if parallel else _clip01((b * f - c * e) / denom)
    t = (b * s + f) / e_safe
    if t < 0.0:
        s = _clip01(-c / a_safe)
    elif t > 1.0:
        s = _clip01((b - c) / a_safe)
    t = _clip01(t)
    if e_pt:
        s = _clip01(-c / a_safe)
        t = 0.0
    if a_pt:
        s = 0.0
        t = 0.0 if e_pt else _clip01(f / e_safe)
    g0 = (p0[0] + s * d10) - (q0[0] + t * d20)
    g1 = (p0[1] + s * d11) - (q0[1] + t * d21)
    g2 = (p0[2] + s * d12) - (q0[2] + t * d22)
    distance = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    if parallel:  # the minimum is attained at an endpoint (s = 0 above is only near it)
        distance = min(distance,
                       _point_segment_distance(p0[0], p0[1], p0[2], q0, d20, d21, d22, e_safe),
                       _point_segment_distance(p1[0], p1[1], p1[2], q0, d20, d21, d22, e_safe),
                       _point_segment_distance(q0[0], q0[1], q0[2], p0, d10, d11, d12, a_safe),
                       _point_segment_distance(q1[0], q1[1], q1[2], p0, d10, d11, d12, a_safe))
    return distance


@jit(**_OPTIONS)
def _point_segment_distance(x0, x1, x2, q0, d0, d1, d2, dd):
    """Distance from point x to segment q0 -> q0 + d (dd = d.d, 1 for a point segment)."""
    w0, w1, w2 = x0 - q0[0], x1 - q0[1], x2 - q0[2]
    s = _clip01((w0 * d0 + w1 * d1 + w2 * d2) / dd)
    g0 = x0 - (q0[0] + s * d0)
    g1 = x1 - (q0[1] + s * d1)
    g2 = x2 - (q0[2] + s * d2)
    return math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)


@jit(**_OPTIONS)
def segment_distances_batch(p0, p1, q0, q1, out):
    """out[n] = the closest distance of segments p0[n]->p1[n] and q0[n]->q1[n] ((N, 3) each)."""
    for n in range(len(out)):
        out[n] = segment_distance(p0[n], p1[n], q0[n], q1[n])


@jit(**_OPTIONS)
def scaled_inverse_jacobian(u, b_in_a, p, scale, J):
    """Rows [u_i, scale * (A_c s'_i) x u_i] (jacobian.inverse_jacobian, angular columns scaled)."""
    for i in range(6):
        ui, c, row = u[i], b_in_a[i], J[i]
        b0, b1, b2 = c[0] - p[0], c[1] - p[1], c[2] - p[2]
        row[0], row[1], row[2] = ui[0], ui[1], ui[2]
        row[3] = scale * (b1 * ui[2] - b2 * ui[1])
        row[4] = scale * (b2 * ui[0] - b0 * ui[2])
        row[5] = scale * (b0 * ui[1] - b1 * ui[0])


@jit(**_OPTIONS)
def inverse_condition(J):  # noqa: C901 - a kernel: flat loops for numba
    """sigma_min / sigma_max of J (6, 6), 0 when sigma_max is 0, NaN when J is not finite, by
    one-sided Jacobi (Hestenes): plane rotations of J's columns until they are orthogonal, the
    singular values then being their norms. Accurate to a few ulps relative even for small
    singular values, and without LAPACK's allocations. Overwrites J."""
    for i in range(6):
        for k in range(6):
            if not math.isfinite(J[i][k]):
                return math.nan
    for _ in range(60):
        rotated = False
        for i in range(5):
            for j in range(i + 1, 6):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(6):
                    row = J[k]
                    alpha += row[i] * row[i]
                    beta += row[j] * row[j]
                    gamma += row[i] * row[j]
                if not abs(gamma) > 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for k in range(6):
                    row = J[k]
                    a, b = row[i], row[j]
                    row[i] = c * a - s * b
                    row[j] = s * a + c * b
        if not rotated:
            break
    smallest = math.inf
    largest = 0.0
    for i in range(6):
        norm = 0.0
        for k in range(6):
            norm += J[k][i] * J[k][i]
        smallest = min(smallest, norm)
        largest = max(largest, norm)
    return math.sqrt(smallest / largest) if largest > 0.0 else 0.0


@jit(**_OPTIONS)
def _limits_at(g, p, R, lengths, universal_angles, spherical_angles, distances, stroke, universal,
               spherical, interference):
    """Every margin of the pose (p, R), per leg and per leg pair (``limits.PAIRS`` order), with
    the lengths, cone angles and leg distances behind them, written in place; returns the
    inverse condition number (NaN when the Jacobian is not finite)."""
    A, B, limits = g.ring_a_anchors, g.ring_b_anchors, g.limits
    b_in_a = matrix(6, 3)
    u = matrix(6, 3)
    pose_in_ring_a(A, B, p, R, b_in_a, u, lengths)
    for i in range(6):
        stroke[i] = min(lengths[i] - limits[0], limits[1] - lengths[i])
        ua = universal_angle(u, g.ring_a_joint_axes, i)
        sa = spherical_angle(u, R, g.ring_b_joint_axes, i)
        universal_angles[i] = ua
        spherical_angles[i] = sa
        universal[i] = limits[2] - ua
        spherical[i] = limits[3] - sa
    k = 0
    for i in range(6):
        for j in range(i + 1, 6):
            distances[k] = segment_distance(A[i], b_in_a[i], A[j], b_in_a[j])
            interference[k] = distances[k] - 2.0 * limits[4]
            k += 1
    J = matrix(6, 6)
    scaled_inverse_jacobian(u, b_in_a, p, 1.0 / limits[5], J)
    return inverse_condition(J)


@jit(**_OPTIONS)
def margins_batch(g, P, R, lengths, universal_angles, spherical_angles, distances, stroke, universal,
                  spherical, interference, inverse_conditions):
    """:func:`_limits_at` of the poses (P[n], R[n]) ((N, 3), (N, 9): rotations row by row), row n of
    each output."""
    for n in range(len(P)):
        inverse_conditions[n] = _limits_at(g, P[n], R[n], lengths[n], universal_angles[n], spherical_angles[n],
                                           distances[n], stroke[n], universal[n], spherical[n], interference[n])


@jit(**_OPTIONS)
def pose_margin_arrays(g, p, q, lengths, stroke, universal, spherical, interference):
    """Every margin of one pose (q a unit quaternion x, y, z, w), per leg (stroke, universal,
    spherical (6,)) and per leg pair (interference (15,)), written in place; returns the inverse
    condition number (NaN when the Jacobian is not finite)."""
    R = floats(9)
    quat_to_matrix(q, R)
    return _limits_at(g, p, R, lengths, floats(6), floats(6), floats(PAIR_COUNT), stroke, universal, spherical,
                      interference)


@jit(**_OPTIONS)
def _smallest(values):
    smallest = math.inf
    for v in values:
        smallest = min(smallest, v)
    return smallest


@jit(**_OPTIONS)
def pose_margins(g, p, q, out, lengths):
    """Smallest margin of each limit of one pose (layout ``N_MARGINS``) and its lengths."""
    stroke, universal, spherical, interference = floats(6), floats(6), floats(6), floats(PAIR_COUNT)
    inv_cond = pose_margin_arrays(g, p, q, lengths, stroke, universal, spherical, interference)
    out[0] = _smallest(stroke)
    out[1] = _smallest(universal)
    out[2] = _smallest(spherical)
    out[3] = _smallest(interference)
    out[4] = inv_cond - g.limits[6]
    out[5] = inv_cond


@jit(**_OPTIONS)
def jacobian_determinant(g, p, q):
    """det J (unscaled inverse Jacobian, rows [u_i, (A_c s'_i) x u_i]) at one pose."""
    R = floats(9)
    quat_to_matrix(q, R)
    b_in_a = matrix(6, 3)
    u = matrix(6, 3)
    pose_in_ring_a(g.ring_a_anchors, g.ring_b_anchors, p, R, b_in_a, u, floats(6))
    J = matrix(6, 6)
    scaled_inverse_jacobian(u, b_in_a, p, 1.0, J)
    return np.linalg.det(J)
