"""Numba kernels for the real-time guards of one pose: every limit's smallest margin, det J.

The same equations as :func:`rrps_kinematics.limits.margins` (the reference, which also words
the reasons) and :func:`rrps_kinematics.jacobian.inverse_jacobian`, for a single pose without
NumPy's per-call overhead: the IK node checks each target in a few microseconds instead of a
few hundred. The tests check both paths give the same numbers. Imported lazily.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from rrps_kinematics.compiled import quat_to_matrix

__all__ = ['pose_margins', 'pose_margin_arrays', 'jacobian_determinant', 'N_MARGINS', 'pose_in_ring_a', 'vector_angle',
           'segment_distance', 'scaled_inverse_jacobian']

_jit = numba.njit(cache=True, nogil=True)

#: Layout of :func:`pose_margins`' output: min stroke, universal, spherical, interference
#: margins, conditioning margin, inverse condition number.
N_MARGINS = 6


@_jit
def pose_in_ring_a(A, B, p, q, R, b_in_a, u, lengths):
    """R(q), ring_b anchors in ring_a's frame, unit leg vectors and lengths (eq. 1)."""
    quat_to_matrix(q, R)
    for i in range(6):
        s = 0.0
        for k in range(3):
            b_in_a[i, k] = p[k] + R[k, 0] * B[i, 0] + R[k, 1] * B[i, 1] + R[k, 2] * B[i, 2]
            d = b_in_a[i, k] - A[i, k]
            u[i, k] = d
            s += d * d
        lengths[i] = math.sqrt(s)
        for k in range(3):
            u[i, k] /= lengths[i]


@_jit
def vector_angle(u0, u1, u2, v0, v1, v2):
    """Angle between unit vectors: atan2(|u x v|, u . v)."""
    c0 = u1 * v2 - u2 * v1
    c1 = u2 * v0 - u0 * v2
    c2 = u0 * v1 - u1 * v0
    return math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), u0 * v0 + u1 * v1 + u2 * v2)


@_jit
def _clip01(x):
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@_jit
def segment_distance(p0, p1, q0, q1):
    """Closest distance of segments p0->p1 and q0->q1; the branches of limits.segment_distances
    (on scalars: no temporary arrays)."""
    d10, d11, d12 = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d20, d21, d22 = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    r0, r1, r2 = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d10 * d10 + d11 * d11 + d12 * d12
    e = d20 * d20 + d21 * d21 + d22 * d22
    b = d10 * d20 + d11 * d21 + d12 * d22
    c = d10 * r0 + d11 * r1 + d12 * r2
    f = d20 * r0 + d21 * r1 + d22 * r2
    tiny = 1e-30
    a_pt = a <= tiny
    e_pt = e <= tiny
    a_safe = 1.0 if a_pt else a
    e_safe = 1.0 if e_pt else e
    denom = a * e - b * b
    parallel = denom <= 1e-12 * a * e
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


@_jit
def _point_segment_distance(x0, x1, x2, q0, d0, d1, d2, dd):
    """Distance from point x to segment q0 -> q0 + d (dd = d.d, 1 for a point segment)."""
    w0, w1, w2 = x0 - q0[0], x1 - q0[1], x2 - q0[2]
    s = _clip01((w0 * d0 + w1 * d1 + w2 * d2) / dd)
    g0 = x0 - (q0[0] + s * d0)
    g1 = x1 - (q0[1] + s * d1)
    g2 = x2 - (q0[2] + s * d2)
    return math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)


@_jit
def scaled_inverse_jacobian(u, b_in_a, p, scale, J):
    """Rows [u_i, scale * (A_c s'_i) x u_i] (jacobian.inverse_jacobian, angular columns scaled)."""
    for i in range(6):
        b0, b1, b2 = b_in_a[i, 0] - p[0], b_in_a[i, 1] - p[1], b_in_a[i, 2] - p[2]
        J[i, 0], J[i, 1], J[i, 2] = u[i, 0], u[i, 1], u[i, 2]
        J[i, 3] = scale * (b1 * u[i, 2] - b2 * u[i, 1])
        J[i, 4] = scale * (b2 * u[i, 0] - b0 * u[i, 2])
        J[i, 5] = scale * (b0 * u[i, 1] - b1 * u[i, 0])


@_jit
def pose_margins(g, p, q, out, lengths):
    """Smallest margin of each limit of one pose (layout ``N_MARGINS``) and its lengths.

    ``g``: the robot as :class:`rrps_kinematics.limits.LimitArrays`; q a unit quaternion
    (x, y, z, w).
    """
    A, B, axes_a, axes_b, limits = (g.ring_a_anchors, g.ring_b_anchors, g.ring_a_joint_axes,
                                    g.ring_b_joint_axes, g.limits)
    R = np.empty((3, 3))
    b_in_a = np.empty((6, 3))
    u = np.empty((6, 3))
    pose_in_ring_a(A, B, p, q, R, b_in_a, u, lengths)
    stroke = np.inf
    universal = np.inf
    spherical = np.inf
    for i in range(6):
        stroke = min(stroke, min(lengths[i] - limits[0], limits[1] - lengths[i]))
        universal = min(universal, limits[2] - vector_angle(u[i, 0], u[i, 1], u[i, 2],
                                                      axes_a[i, 0], axes_a[i, 1], axes_a[i, 2]))
        # the leg from the S-joint towards ring_a in ring_b's frame: -R^T u
        t0 = -(R[0, 0] * u[i, 0] + R[1, 0] * u[i, 1] + R[2, 0] * u[i, 2])
        t1 = -(R[0, 1] * u[i, 0] + R[1, 1] * u[i, 1] + R[2, 1] * u[i, 2])
        t2 = -(R[0, 2] * u[i, 0] + R[1, 2] * u[i, 1] + R[2, 2] * u[i, 2])
        spherical = min(spherical, limits[3] - vector_angle(t0, t1, t2, axes_b[i, 0], axes_b[i, 1], axes_b[i, 2]))
    interference = np.inf
    for i in range(6):
        for j in range(i + 1, 6):
            dist = segment_distance(A[i], b_in_a[i], A[j], b_in_a[j])
            interference = min(interference, dist - 2.0 * limits[4])
    J = np.empty((6, 6))
    scaled_inverse_jacobian(u, b_in_a, p, 1.0 / limits[5], J)
    inv_cond = 0.0
    finite = True
    for i in range(6):
        for k in range(6):
            if not math.isfinite(J[i, k]):
                finite = False
    if finite:
        sv = np.linalg.svd(J)[1]
        if sv[0] > 0.0:
            inv_cond = sv[5] / sv[0]
    else:
        inv_cond = np.nan
    out[0] = stroke
    out[1] = universal
    out[2] = spherical
    out[3] = interference
    out[4] = inv_cond - limits[6]
    out[5] = inv_cond


@_jit
def pose_margin_arrays(g, p, q, lengths, stroke, universal, spherical, interference):
    """Every margin of one pose, per leg (stroke, universal, spherical (6,)) and per leg pair
    (interference (15,), in ``limits.PAIRS`` order), written in place; returns the inverse
    condition number (NaN when the Jacobian is not finite). The numbers of ``limits.margins``."""
    A, B, axes_a, axes_b, limits = (g.ring_a_anchors, g.ring_b_anchors, g.ring_a_joint_axes,
                                    g.ring_b_joint_axes, g.limits)
    R = np.empty((3, 3))
    b_in_a = np.empty((6, 3))
    u = np.empty((6, 3))
    pose_in_ring_a(A, B, p, q, R, b_in_a, u, lengths)
    for i in range(6):
        stroke[i] = min(lengths[i] - limits[0], limits[1] - lengths[i])
        universal[i] = limits[2] - vector_angle(u[i, 0], u[i, 1], u[i, 2],
                                                axes_a[i, 0], axes_a[i, 1], axes_a[i, 2])
        t0 = -(R[0, 0] * u[i, 0] + R[1, 0] * u[i, 1] + R[2, 0] * u[i, 2])
        t1 = -(R[0, 1] * u[i, 0] + R[1, 1] * u[i, 1] + R[2, 1] * u[i, 2])
        t2 = -(R[0, 2] * u[i, 0] + R[1, 2] * u[i, 1] + R[2, 2] * u[i, 2])
        spherical[i] = limits[3] - vector_angle(t0, t1, t2, axes_b[i, 0], axes_b[i, 1], axes_b[i, 2])
    k = 0
    for i in range(6):
        for j in range(i + 1, 6):
            interference[k] = segment_distance(A[i], b_in_a[i], A[j], b_in_a[j]) - 2.0 * limits[4]
            k += 1
    J = np.empty((6, 6))
    scaled_inverse_jacobian(u, b_in_a, p, 1.0 / limits[5], J)
    for i in range(6):
        for c in range(6):
            if not math.isfinite(J[i, c]):
                return np.nan
    sv = np.linalg.svd(J)[1]
    return sv[5] / sv[0] if sv[0] > 0.0 else 0.0


@_jit
def jacobian_determinant(g, p, q):
    """det J (unscaled inverse Jacobian, rows [u_i, (A_c s'_i) x u_i]) at one pose."""
    A, B = g.ring_a_anchors, g.ring_b_anchors
    R = np.empty((3, 3))
    b_in_a = np.empty((6, 3))
    u = np.empty((6, 3))
    lengths = np.empty(6)
    pose_in_ring_a(A, B, p, q, R, b_in_a, u, lengths)
    J = np.empty((6, 6))
    scaled_inverse_jacobian(u, b_in_a, p, 1.0, J)
    return np.linalg.det(J)
