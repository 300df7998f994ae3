"""Compiled kernels of the 13-body dynamics: eq. 19 at one state, and what is observed of a state.

Velocities are v = [ṙ_b, ω'_b] per body (78,), ω' in the body frame; positions are the 91
coordinates of :mod:`rrps_kinematics.multibody`. Eq. 19 is

    [M    0    Φ_r^T ] [ r̈  ]   [ F^A            ]
    [0    J'   Φ_π'^T] [ ω̇' ] = [ n' - ω̃' J' ω'  ]
    [Φ_r  Φ_π' 0     ] [ λ  ]   [ γ              ]

with F^A gravity plus each actuator force f_k applied along leg k's axis, -f_k h on the lower
link and +f_k h on the upper link (f > 0 pushes the rings apart). It is solved exactly, by the
structure of the robot: M^-1 is block diagonal and leg k's 12 constraint rows touch only its two
links and ring_b, so the Schur complement Φ M^-1 Φ^T = D + U M_b^-1 U^T is six 12 x 12 blocks
plus a rank-6 ring_b coupling, solved by Cholesky per leg and the Woodbury identity (a 6 x 6
solve).

Every kernel takes the robot as one :class:`DynamicsParameters` bundle (a NamedTuple of arrays,
which numba passes as one typed argument).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import JointGeometry, leg_residual, rotation

__all__ = ['DynamicsParameters', 'Observation', 'accelerations', 'drift_and_norm', 'leg_blocks',
           'leg_lengths_rates', 'observe']


class DynamicsParameters(NamedTuple):
    """The robot as the kernels see it: its joints (eqs. 3-10) and its 13 bodies' inertia.

    ``mass`` (13,) [kg], ``inertia`` (13, 3, 3) J' about each com in the body frame [kg m^2] and
    its inverse ``inertia_inv``, ``gravity`` (3,) in ring_a's frame [m/s^2], ``com_b`` (3,)
    ring_b's com in its frame [m]. Body 0 is ring_b, 1 + 2k and 2 + 2k leg k's lower and upper
    link.
    """

    joints: JointGeometry
    mass: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    gravity: np.ndarray
    com_b: np.ndarray

    @classmethod
    def of(cls, geometry, joints: JointGeometry) -> DynamicsParameters:
        """The bundle of a RobotGeometry whose multibody model has these joints."""
        mass = np.empty(13)
        inertia = np.empty((13, 3, 3))
        mass[0] = geometry.ring_b_inertia.mass
        inertia[0] = geometry.ring_b_inertia.inertia
        for k in range(6):
            mass[1 + 2 * k] = geometry.lower_link.mass
            inertia[1 + 2 * k] = geometry.lower_link.inertia_tensor()
            mass[2 + 2 * k] = geometry.upper_link.mass
            inertia[2 + 2 * k] = geometry.upper_link.inertia_tensor()
        return cls(joints, mass, inertia, np.linalg.inv(inertia),
                   np.ascontiguousarray(geometry.gravity, dtype=float),
                   np.ascontiguousarray(geometry.ring_b_inertia.com, dtype=float))


class Observation(NamedTuple):
    """What is reported of one state: ring_b's ``position`` (3,) [m] and unit ``euler_parameters``
    (e0, e1, e2, e3) in ring_a's frame, actuator ``lengths`` (6,) [m] and ``length_rates`` (6,)
    [m/s], ``constraint_drift`` ‖Φ^K‖, ``euler_norm_error`` max_b |p_b^T p_b - 1| (eq. 9),
    ``kinetic`` Σ ½ m |ṙ|² + ½ ω'^T J' ω' and ``potential`` -Σ m g·r energies [J]."""

    position: np.ndarray
    euler_parameters: np.ndarray
    lengths: np.ndarray
    length_rates: np.ndarray
    constraint_drift: float
    euler_norm_error: float
    kinetic: float
    potential: float


@jit
def _cross(a, b):
    """a × b of two 3-vectors (tuples or arrays) as a tuple: no allocation."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def _col(A, j, scale):
    return (scale * A[0, j], scale * A[1, j], scale * A[2, j])


@jit
def _matvec(A, x):
    return (A[0, 0] * x[0] + A[0, 1] * x[1] + A[0, 2] * x[2],
            A[1, 0] * x[0] + A[1, 1] * x[1] + A[1, 2] * x[2],
            A[2, 0] * x[0] + A[2, 1] * x[1] + A[2, 2] * x[2])


@jit
def _matvec6(W, x):
    out = np.empty(6)
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += W[i, j] * x[j]
        out[i] = s
    return out


@jit
def _omega(A, v, b):
    """Global angular velocity ω = A ω' of body b."""
    o = 6 * b + 3
    return _matvec(A, (v[o], v[o + 1], v[o + 2]))


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
        x = _cross(a, c)
        for i in range(3):
            B[row, ci + i] = x[i]
    x = _cross(c, a)
    for i in range(3):
        B[row, cj + i] = x[i]
    wa = _cross(wi, a)
    wc = _cross(wj, c)
    gamma[row] = -(_dot(_cross(wi, wa), c) + 2.0 * _dot(wa, wc) + _dot(a, _cross(wj, wc)))


@jit
def leg_blocks(q, v, k, joints, B, gamma):
    """Leg k's 13 rows (12 joint + driving) of [Φ_r Φ_π'] (13 x 18) and γ (13,) of eq. 19.

    Columns: ring_b [r, π'], lower link [r, π'], upper link [r, π']. Rows are first written
    for global virtual rotations π (δa = δπ × a), then Φ_π' = Φ_π A."""
    ha, sb, cl, cu = joints.ha, joints.sb, joints.cl, joints.cu
    B[:, :] = 0.0
    bl = 1 + 2 * k
    bu = 2 + 2 * k
    Ab = rotation(q, 3)
    Al = rotation(q, 7 * bl + 3)
    Au = rotation(q, 7 * bu + 3)
    wb = _omega(Ab, v, 0)
    wl = _omega(Al, v, bl)
    wu = _omega(Au, v, bu)
    s_b = _matvec(Ab, (sb[k, 0], sb[k, 1], sb[k, 2]))
    s_u = _col(Au, 2, cu)
    s_l = _col(Al, 2, -cl)
    f_l = _col(Al, 0, 1.0)
    g_l = _col(Al, 1, 1.0)
    h_l = _col(Al, 2, 1.0)
    g_u = _col(Au, 1, 1.0)
    h_u = _col(Au, 2, 1.0)
    wsu = _cross(wu, s_u)
    wsl = _cross(wl, s_l)
    ol = 7 * bl
    ou = 7 * bu
    d = (q[ou] + s_u[0] - q[ol] - s_l[0], q[ou + 1] + s_u[1] - q[ol + 1] - s_l[1],
         q[ou + 2] + s_u[2] - q[ol + 2] - s_l[2])
    vl = 6 * bl
    vu = 6 * bu
    dd = (v[vu] + wsu[0] - v[vl] - wsl[0], v[vu + 1] + wsu[1] - v[vl + 1] - wsl[1],
          v[vu + 2] + wsu[2] - v[vl + 2] - wsl[2])
    quad_u = _cross(wu, wsu)
    quad_l = _cross(wl, wsl)
    quad_b = _cross(wb, _cross(wb, s_b))
    # spherical (eq. 3): r_u + s_u - r_b - s_b
    for i in range(3):
        B[i, 12 + i] = 1.0
        B[i, i] = -1.0
        gamma[i] = -quad_u[i] + quad_b[i]
    _skew_cols(B, 0, 15, s_u, -1.0)
    _skew_cols(B, 0, 3, s_b, 1.0)
    # universal, spherical part (eq. 4): r_l + s_l - a
    for i in range(3):
        B[3 + i, 6 + i] = 1.0
        gamma[3 + i] = -quad_l[i]
    _skew_cols(B, 3, 9, s_l, -1.0)
    # universal dot-1 (eq. 5), translational (eqs. 6, 8)
    _dot_row(B, 6, -1, (ha[k, 0], ha[k, 1], ha[k, 2]), (0.0, 0.0, 0.0), 9, g_l, wl, gamma)
    _dot_row(B, 7, 9, f_l, wl, 15, h_u, wu, gamma)
    _dot_row(B, 8, 9, g_l, wl, 15, h_u, wu, gamma)
    _dot_row(B, 11, 9, f_l, wl, 15, g_u, wu, gamma)
    # translational (eq. 7) and driving (eq. 10): e·d with e on the lower link
    dquad = (quad_u[0] - quad_l[0], quad_u[1] - quad_l[1], quad_u[2] - quad_l[2])
    for row in (9, 10, 12):
        e = f_l if row == 9 else (g_l if row == 10 else h_l)
        x = _cross(e, d)
        y = _cross(s_l, e)
        z = _cross(s_u, e)
        for i in range(3):
            B[row, 12 + i] = e[i]
            B[row, 6 + i] = -e[i]
            B[row, 9 + i] = x[i] - y[i]
            B[row, 15 + i] = z[i]
        we = _cross(wl, e)
        gamma[row] = -(_dot(_cross(wl, we), d) + 2.0 * _dot(we, dd) + _dot(e, dquad))
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


@jit(fastmath=True)
def _cholesky(A, n):
    """In-place lower Cholesky factor of the SPD n x n matrix A; False if not positive."""
    for j in range(n):
        s = A[j, j]
        for m in range(j):
            s -= A[j, m] * A[j, m]
        if s <= 0.0:
            return False
        ljj = math.sqrt(s)
        A[j, j] = ljj
        for i in range(j + 1, n):
            s = A[i, j]
            for m in range(j):
                s -= A[i, m] * A[j, m]
            A[i, j] = s / ljj
    return True


@jit(fastmath=True)
def _cholesky_solve(Lc, X, n, nrhs):
    """Solve (Lc Lc^T) X = X in place for nrhs columns."""
    for c in range(nrhs):
        for i in range(n):
            s = X[i, c]
            for m in range(i):
                s -= Lc[i, m] * X[m, c]
            X[i, c] = s / Lc[i, i]
        for i in range(n - 1, -1, -1):
            s = X[i, c]
            for m in range(i + 1, n):
                s -= Lc[m, i] * X[m, c]
            X[i, c] = s / Lc[i, i]


@jit(fastmath=True)
def accelerations(q, v, forces, alpha, beta, params, acc, lam):
    """Solve eq. 19 for [r̈, ω̇'] (78,) -> acc and λ (72,) -> lam; returns False if singular.

    Baumgarte stabilisation with α, β (0, 0: none): γ <- γ - 2 α Φ̇ - β² Φ (joint rows)."""
    joints, mass, inertia = params.joints, params.mass, params.inertia
    inertia_inv, gravity = params.inertia_inv, params.gravity
    F = np.empty(78)
    for b in range(13):
        w = (v[6 * b + 3], v[6 * b + 4], v[6 * b + 5])
        gyro = _cross(w, _matvec(inertia[b], w))
        for i in range(3):
            F[6 * b + i] = mass[b] * gravity[i]
            F[6 * b + 3 + i] = -gyro[i]
    B = np.empty((13, 18))
    gamma = np.empty(13)
    res = np.empty(13)
    legB = np.empty((6, 12, 18))
    X = np.empty((6, 12, 7))
    Lc = np.empty((12, 12))
    BW = np.empty((12, 12))
    S = np.zeros((6, 6))
    t = np.zeros(6)
    Wb = np.zeros((6, 6))
    Sm = np.zeros((6, 6))
    for i in range(3):
        Wb[i, i] = 1.0 / mass[0]
        Sm[i, i] = mass[0]
        for j in range(3):
            Wb[3 + i, 3 + j] = inertia_inv[0, i, j]
            Sm[3 + i, 3 + j] = inertia[0, i, j]
    for k in range(6):
        bl = 1 + 2 * k
        bu = 2 + 2 * k
        leg_blocks(q, v, k, joints, B, gamma)
        Al = rotation(q, 7 * bl + 3)
        for i in range(3):
            F[6 * bl + i] -= forces[k] * Al[i, 2]
            F[6 * bu + i] += forces[k] * Al[i, 2]
        if alpha != 0.0 or beta != 0.0:
            leg_residual(q, k, 0.0, joints, res)
            idx = (0, bl, bu)
            for r in range(12):
                phidot = 0.0
                for blk in range(3):
                    o = 6 * idx[blk]
                    for j in range(6):
                        phidot += B[r, 6 * blk + j] * v[o + j]
                gamma[r] -= 2.0 * alpha * phidot + beta * beta * res[r]
        legB[k] = B[:12]
        # B W for the two links; D = Σ B W B^T; right-hand sides [U | Φ W F - γ]
        for blk in range(2):
            body = bl if blk == 0 else bu
            c0 = 6 + 6 * blk
            for r in range(12):
                for i in range(3):
                    BW[r, 6 * blk + i] = B[r, c0 + i] / mass[body]
                for j in range(3):
                    s = 0.0
                    for i in range(3):
                        s += B[r, c0 + 3 + i] * inertia_inv[body, i, j]
                    BW[r, 6 * blk + 3 + j] = s
        for r in range(12):
            for c in range(r + 1):
                s = 0.0
                for j in range(12):
                    s += BW[r, j] * B[c, 6 + j]
                Lc[r, c] = s
                Lc[c, r] = s
        if not _cholesky(Lc, 12):
            return False
        WbFb = _matvec6(Wb, F[0:6])
        for r in range(12):
            for j in range(6):
                X[k, r, j] = B[r, j]
            s = -gamma[r]
            for j in range(6):
                s += B[r, j] * WbFb[j] + BW[r, j] * F[6 * bl + j] + BW[r, 6 + j] * F[6 * bu + j]
            X[k, r, 6] = s
        _cholesky_solve(Lc, X[k], 12, 7)
        for i in range(6):
            for j in range(6):
                s = 0.0
                for r in range(12):
                    s += B[r, i] * X[k, r, j]
                S[i, j] += s
            s = 0.0
            for r in range(12):
                s += B[r, i] * X[k, r, 6]
            t[i] += s
    S += Sm
    if not _cholesky(S, 6):
        return False
    z = t.reshape((6, 1)).copy()
    _cholesky_solve(S, z, 6, 1)
    Fb = F[0:6].copy()
    for k in range(6):
        bl = 1 + 2 * k
        bu = 2 + 2 * k
        for r in range(12):
            s = X[k, r, 6]
            for j in range(6):
                s -= X[k, r, j] * z[j, 0]
            lam[12 * k + r] = s
        for j in range(6):
            s_b = 0.0
            s_l = 0.0
            s_u = 0.0
            for r in range(12):
                lr = lam[12 * k + r]
                s_b += legB[k, r, j] * lr
                s_l += legB[k, r, 6 + j] * lr
                s_u += legB[k, r, 12 + j] * lr
            Fb[j] -= s_b
            F[6 * bl + j] -= s_l
            F[6 * bu + j] -= s_u
        # links: M^-1 (F - Φ^T λ)
        for body in (bl, bu):
            for i in range(3):
                acc[6 * body + i] = F[6 * body + i] / mass[body]
            o = 6 * body + 3
            wdot = _matvec(inertia_inv[body], (F[o], F[o + 1], F[o + 2]))
            for i in range(3):
                acc[o + i] = wdot[i]
    acc[0:6] = _matvec6(Wb, Fb)
    return True


@jit
def leg_lengths_rates(q, v, joints):
    """Actuator lengths and rates from ring_b's state: S_k = r_b + A_b s'_k, L = |S_k - a_k|."""
    a, sb = joints.a, joints.sb
    Ab = rotation(q, 3)
    wb = _omega(Ab, v, 0)
    L = np.empty(6)
    Ld = np.empty(6)
    for k in range(6):
        s = _matvec(Ab, (sb[k, 0], sb[k, 1], sb[k, 2]))
        ws = _cross(wb, s)
        d = (q[0] + s[0] - a[k, 0], q[1] + s[1] - a[k, 1], q[2] + s[2] - a[k, 2])
        n = math.sqrt(_dot(d, d))
        L[k] = n
        Ld[k] = (_dot(d, v[0:3]) + _dot(d, ws)) / n
    return L, Ld


@jit
def drift_and_norm(q, joints):
    """‖Φ^K‖ (2-norm of the 72 joint constraints) and max_b |p_b^T p_b - 1|."""
    res = np.empty(13)
    s = 0.0
    for k in range(6):
        leg_residual(q, k, 0.0, joints, res)
        for i in range(12):
            s += res[i] * res[i]
    n = 0.0
    for b in range(13):
        o = 7 * b + 3
        n = max(n, abs(q[o] ** 2 + q[o + 1] ** 2 + q[o + 2] ** 2 + q[o + 3] ** 2 - 1.0))
    return math.sqrt(s), n


@jit
def observe(q, v, params):
    """Everything reported about a state, in one pass: an :class:`Observation`."""
    mass, inertia, gravity, com_b = params.mass, params.inertia, params.gravity, params.com_b
    euler = np.empty(4)
    n = math.sqrt(q[3] ** 2 + q[4] ** 2 + q[5] ** 2 + q[6] ** 2)
    for i in range(4):
        euler[i] = q[3 + i] / n
    c = _matvec(rotation(euler, 0), (com_b[0], com_b[1], com_b[2]))
    position = np.empty(3)
    for i in range(3):
        position[i] = q[i] - c[i]
    L, Ld = leg_lengths_rates(q, v, params.joints)
    drift, norm_error = drift_and_norm(q, params.joints)
    kin = 0.0
    pot = 0.0
    for b in range(13):
        o = 6 * b
        w = (v[o + 3], v[o + 4], v[o + 5])
        kin += 0.5 * mass[b] * (v[o] ** 2 + v[o + 1] ** 2 + v[o + 2] ** 2)
        kin += 0.5 * _dot(w, _matvec(inertia[b], w))
        pot -= mass[b] * (gravity[0] * q[7 * b] + gravity[1] * q[7 * b + 1] + gravity[2] * q[7 * b + 2])
    return Observation(position, euler, L, Ld, drift, norm_error, kin, pot)

