"""The constraint rows of eq. 19 for one leg: [Φ_r Φ_π'] and γ (eqs. 3-10, 19), and its joint
residual, for either ring grounded.

Φ_π' = Φ_π A (A the body's rotation); γ is the acceleration right-hand side, Φ_x ẍ = γ. With
ring_a grounded (``support`` 0, the paper's case) the hub ring_b carries the spherical joints
(rows 0-2, eq. 3); with ring_b grounded the hub ring_a carries the universal joints (rows 3-6).
Rows 7-12 (the prismatic pair and the driving constraint) involve the two links only.
"""

from __future__ import annotations

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import rotation

__all__ = ['angular_velocity', 'cross3', 'dot3', 'leg_blocks', 'leg_blocks_with_rotations',
           'matvec3', 'ring_b_grounded_residual']


@jit
def cross3(a, b):
    """a × b of two 3-vectors (tuples or arrays) as a tuple: no allocation."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def dot3(a, b):
    """a · b of two 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def _col(A, j, scale):
    return (scale * A[0, j], scale * A[1, j], scale * A[2, j])


@jit
def matvec3(A, x):
    """A x of a 3 x 3 matrix and a 3-vector, as a tuple."""
    return (A[0, 0] * x[0] + A[0, 1] * x[1] + A[0, 2] * x[2],
            A[1, 0] * x[0] + A[1, 1] * x[1] + A[1, 2] * x[2],
            A[2, 0] * x[0] + A[2, 1] * x[1] + A[2, 2] * x[2])


@jit
def angular_velocity(A, v, b):
    """Global angular velocity ω = A ω' of body b."""
    o = 6 * b + 3
    return matvec3(A, (v[o], v[o + 1], v[o + 2]))


@jit
def _skew_cols(B, row, c0, s, sign):
    """B[row:row+3, c0:c0+3] = sign * s̃ (the π columns of ±(A s'))."""
    B[row, c0 + 1] = -sign * s[2]
    B[row, c0 + 2] = sign * s[1]
    B[row + 1, c0] = sign * s[2]
    B[row + 1, c0 + 2] = -sign * s[0]
    B[row + 2, c0] = -sign * s[1]
    B[row + 2, c0 + 1] = sign * s[0]


@jit
def _dot_row(B, row, ci, a, wi, cj, c, wj, gamma):
    """Row of a dot-1 constraint a·c (a on body ci, c on body cj, global π columns) and its γ.

    ci is the first rotational column of a's body in B (-1: ground)."""
    if ci >= 0:
        x = cross3(a, c)
        for i in range(3):
            B[row, ci + i] = x[i]
    x = cross3(c, a)
    for i in range(3):
        B[row, cj + i] = x[i]
    wa = cross3(wi, a)
    wc = cross3(wj, c)
    gamma[row] = -(dot3(cross3(wi, wa), c) + 2.0 * dot3(wa, wc) + dot3(a, cross3(wj, wc)))


@jit
def ring_b_grounded_residual(q, k, joints, Ab, Al, Au, out):
    """Rows 0-6 of leg k's joint residual with ring_b grounded (the hub, ring_a, carries the
    universal joints) -> out[0:7], over the ring_a-grounded rows that
    :func:`~rrps_kinematics.multibody.leg_residual_with_rotations` wrote there; its rows 7-12
    (the prismatic pair, the driving row) hold for either support."""
    a, ha, sb, cl, cu = joints
    ol = 7 * (1 + 2 * k)
    ou = 7 * (2 + 2 * k)
    h = matvec3(Ab, (ha[k, 0], ha[k, 1], ha[k, 2]))
    for i in range(3):
        s_h = Ab[i, 0] * sb[k, 0] + Ab[i, 1] * sb[k, 1] + Ab[i, 2] * sb[k, 2]
        out[i] = q[ou + i] + Au[i, 2] * cu - a[k, i]
        out[3 + i] = q[ol + i] - Al[i, 2] * cl - q[i] - s_h
    out[6] = h[0] * Al[0, 1] + h[1] * Al[1, 1] + h[2] * Al[2, 1]


@jit
def leg_blocks(q, v, k, joints, support, B, gamma):
    """Leg k's 13 rows (12 joint + driving) of [Φ_r Φ_π'] (13 x 18) and γ (13,) of eq. 19.

    Columns: the hub [r, π'], lower link [r, π'], upper link [r, π']. Rows are first written
    for global virtual rotations π (δa = δπ × a), then Φ_π' = Φ_π A."""
    leg_blocks_with_rotations(q, v, k, joints, support, rotation(q, 3), rotation(q, 7 * (1 + 2 * k) + 3),
                              rotation(q, 7 * (2 + 2 * k) + 3), B, gamma)


@jit
def leg_blocks_with_rotations(q, v, k, joints, support, Ab, Al, Au, B, gamma):
    """:func:`leg_blocks` with the rotations of the hub and leg k's links given."""
    ha, sb, cl, cu = joints.ha, joints.sb, joints.cl, joints.cu
    B[:, :] = 0.0
    bl = 1 + 2 * k
    bu = 2 + 2 * k
    wb = angular_velocity(Ab, v, 0)
    wl = angular_velocity(Al, v, bl)
    wu = angular_velocity(Au, v, bu)
    s_b = matvec3(Ab, (sb[k, 0], sb[k, 1], sb[k, 2]))
    s_u = _col(Au, 2, cu)
    s_l = _col(Al, 2, -cl)
    f_l = _col(Al, 0, 1.0)
    g_l = _col(Al, 1, 1.0)
    h_l = _col(Al, 2, 1.0)
    g_u = _col(Au, 1, 1.0)
    h_u = _col(Au, 2, 1.0)
    wsu = cross3(wu, s_u)
    wsl = cross3(wl, s_l)
    ol = 7 * bl
    ou = 7 * bu
    d = (q[ou] + s_u[0] - q[ol] - s_l[0], q[ou + 1] + s_u[1] - q[ol + 1] - s_l[1],
         q[ou + 2] + s_u[2] - q[ol + 2] - s_l[2])
    vl = 6 * bl
    vu = 6 * bu
    dd = (v[vu] + wsu[0] - v[vl] - wsl[0], v[vu + 1] + wsu[1] - v[vl + 1] - wsl[1],
          v[vu + 2] + wsu[2] - v[vl + 2] - wsl[2])
    quad_u = cross3(wu, wsu)
    quad_l = cross3(wl, wsl)
    quad_b = cross3(wb, cross3(wb, s_b))
    # spherical (eq. 3): r_u + s_u - (r_b + s_b | a); universal, spherical part (eq. 4):
    # r_l + s_l - (a | r_h + s_h); the hub's terms on the rows of its joint
    hub = 0 if support == 0 else 3
    for i in range(3):
        B[i, 12 + i] = 1.0
        B[3 + i, 6 + i] = 1.0
        B[hub + i, i] = -1.0
        gamma[i] = -quad_u[i]
        gamma[3 + i] = -quad_l[i]
        gamma[hub + i] += quad_b[i]
    _skew_cols(B, 0, 15, s_u, -1.0)
    _skew_cols(B, 3, 9, s_l, -1.0)
    _skew_cols(B, hub, 3, s_b, 1.0)
    # universal dot-1 (eq. 5): the axis fixed in ring_a, ground or hub; translational (eqs. 6, 8)
    if support == 0:
        _dot_row(B, 6, -1, (ha[k, 0], ha[k, 1], ha[k, 2]), (0.0, 0.0, 0.0), 9, g_l, wl, gamma)
    else:
        _dot_row(B, 6, 3, matvec3(Ab, (ha[k, 0], ha[k, 1], ha[k, 2])), wb, 9, g_l, wl, gamma)
    _dot_row(B, 7, 9, f_l, wl, 15, h_u, wu, gamma)
    _dot_row(B, 8, 9, g_l, wl, 15, h_u, wu, gamma)
    _dot_row(B, 11, 9, f_l, wl, 15, g_u, wu, gamma)
    # translational (eq. 7) and driving (eq. 10): e·d with e on the lower link
    dquad = (quad_u[0] - quad_l[0], quad_u[1] - quad_l[1], quad_u[2] - quad_l[2])
    for row in (9, 10, 12):
        e = f_l if row == 9 else (g_l if row == 10 else h_l)
        x = cross3(e, d)
        y = cross3(s_l, e)
        z = cross3(s_u, e)
        for i in range(3):
            B[row, 12 + i] = e[i]
            B[row, 6 + i] = -e[i]
            B[row, 9 + i] = x[i] - y[i]
            B[row, 15 + i] = z[i]
        we = cross3(wl, e)
        gamma[row] = -(dot3(cross3(wl, we), d) + 2.0 * dot3(we, dd) + dot3(e, dquad))
    # global π columns -> body π' columns: Φ_π' = Φ_π A
    for blk in range(3):
        A = Ab if blk == 0 else (Al if blk == 1 else Au)
        c0 = 3 + 6 * blk
        for r in range(13):
            x0 = B[r, c0]
            x1 = B[r, c0 + 1]
            x2 = B[r, c0 + 2]
            if x0 != 0.0 or x1 != 0.0 or x2 != 0.0:
                for j in range(3):
                    B[r, c0 + j] = x0 * A[0, j] + x1 * A[1, j] + x2 * A[2, j]
