"""Forward dynamics of the 13-body RRPS model: the DAE of eqs. 19-20 (paper section 2.3).

Positions are the 91 coordinates of :mod:`rrps_kinematics.multibody` (com and Euler parameters
of ring_b and the 12 leg links); velocities are v = [ṙ_b, ω'_b] per body (78,), ω' in the body
frame. With actuator *forces* applied (not lengths), the 72 joint constraints Φ^K leave 6 DOF.
Eq. 19 is

    [M    0    Φ_r^T ] [ r̈  ]   [ F^A            ]
    [0    J'   Φ_π'^T] [ ω̇' ] = [ n' - ω̃' J' ω'  ]
    [Φ_r  Φ_π' 0     ] [ λ  ]   [ γ              ]

with F^A gravity plus each actuator force f_k applied along leg k's axis, -f_k h on the lower
link and +f_k h on the upper link (f > 0 pushes the rings apart). It is solved exactly, by the
structure of the robot: M^-1 is block diagonal and leg k's 12 constraint rows touch only its two
links and ring_b, so the Schur complement Φ M^-1 Φ^T = D + U M_b^-1 U^T is six 12 x 12 blocks
plus a rank-6 ring_b coupling, solved by Cholesky per leg and the Woodbury identity (a 6 x 6
solve). Euler parameters follow ṗ = ½ G^T ω' (G = [-e, -ẽ + e0 I]).

Integrators (all classical RK4 on the index-1 accelerations, step = the user's dt):

* ``baumgarte``: constraint stabilisation, γ <- γ - 2 α Φ̇ - β² Φ, all 91 + 78 states integrated.
* ``partitioning``: coordinate partitioning. Independent coordinates: ring_b's com position and
  Euler vector part (e1, e2, e3) with their velocities (ṙ_b, ω'_b); dependent: ring_b's e0 (eq. 9)
  and the 84 leg-link coordinates, solved by Newton-Raphson on the constraints (eqs. 3-9, per
  leg: 14 equations in 14 unknowns), the dependent velocities from Φ_q v = 0 (eq. 20).
* ``hybrid``: the paper's choice: Baumgarte-stabilised integration of all states and, whenever
  the drift ‖Φ‖ or an Euler-parameter norm error exceeds ``correction_tolerance``, the partitioned
  correction (Newton on the dependent coordinates, velocity projection).

Energy balance: kinetic + potential - actuator work (∫ Σ f_k L̇_k dt, integrated with the
states), minus its initial value, so an exact solution keeps it at zero.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np

from rrps_kinematics.geometry import RobotGeometry
from rrps_kinematics.inverse import pose_arrays
from rrps_kinematics.multibody import (
    FLOPS_LEG_JACOBIAN,
    FLOPS_LEG_RESIDUAL,
    FLOPS_ROTATION,
    MultibodyModel,
    gauss_eliminate,
    leg_jacobian,
    leg_residual,
    rotation,
)
from rrps_kinematics.rotations import euler_parameters_to_quat_xyzw, normalize_quat

__all__ = ['METHODS', 'MultibodyDynamics', 'SimulationResult', 'simulate']

METHODS = ('baumgarte', 'partitioning', 'hybrid')

# Flop model of one evaluation of eq. 19 (multiply and add count one each), by formula from the
# loops of `accelerations` (per leg, then once):
_LEG_BLOCKS = 13 * 3 * 3 * 5 + 700        # Φ_π' = Φ_π A for 3 bodies; vectors, crosses, γ
_LEG_SCHUR = (12 * 21                     # B W of the two links
              + 78 * 12 * 2               # D = Σ B W B^T, lower triangle
              + 12**3 // 3 + 7 * 2 * 12**2   # Cholesky of D, 7 right-hand sides
              + 36 * 12 * 2 + 6 * 12 * 2  # S and t accumulation (Woodbury)
              + 12 * 18 * 2               # Φ W F - γ
              + 12 * 6 * 2 + 18 * 12 * 2)   # λ and Φ^T λ
_BAUMGARTE_LEG = FLOPS_LEG_RESIDUAL + 12 * 18 * 2   # Φ and Φ̇ = Φ_x v
EVALUATION_FLOPS = (13 * FLOPS_ROTATION + 13 * 40                     # rotations, F^A, gyroscopic
                    + 6 * (_LEG_BLOCKS + _LEG_SCHUR) + 6**3 // 3 + 4 * 6**2 + 78 * 5)
NEWTON_LEG_FLOPS = FLOPS_LEG_RESIDUAL + FLOPS_LEG_JACOBIAN + (2 * 14**3) // 3 + 2 * 14**2
VELOCITY_LEG_FLOPS = _LEG_BLOCKS + (2 * 12**3) // 3 + 2 * 12**2 + 12 * 6 * 2


# --- compiled kernels --------------------------------------------------------------------------

@numba.njit(cache=True)
def _cross(a, b):
    """a × b of two 3-vectors (tuples or arrays) as a tuple: no allocation."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(cache=True)
def _col(A, j, scale):
    return (scale * A[0, j], scale * A[1, j], scale * A[2, j])


@numba.njit(cache=True)
def _matvec(A, x):
    return (A[0, 0] * x[0] + A[0, 1] * x[1] + A[0, 2] * x[2],
            A[1, 0] * x[0] + A[1, 1] * x[1] + A[1, 2] * x[2],
            A[2, 0] * x[0] + A[2, 1] * x[1] + A[2, 2] * x[2])


@numba.njit(cache=True)
def _matvec6(W, x):
    out = np.empty(6)
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += W[i, j] * x[j]
        out[i] = s
    return out


@numba.njit(cache=True)
def _omega(A, v, b):
    """Global angular velocity ω = A ω' of body b."""
    o = 6 * b + 3
    return _matvec(A, (v[o], v[o + 1], v[o + 2]))


@numba.njit(cache=True)
def _skew_cols(B, row, c0, s, sign):
    """B[row:row+3, c0:c0+3] = sign * s̃ (the π columns of ±(A s'))."""
    B[row, c0 + 1] = -sign * s[2]
    B[row, c0 + 2] = sign * s[1]
    B[row + 1, c0] = sign * s[2]
    B[row + 1, c0 + 2] = -sign * s[0]
    B[row + 2, c0] = -sign * s[1]
    B[row + 2, c0 + 1] = sign * s[0]


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def leg_blocks(q, v, k, a, ha, sb, cl, cu, B, gamma):
    """Leg k's 13 rows (12 joint + driving) of [Φ_r Φ_π'] (13 x 18) and γ (13,) of eq. 19.

    Columns: ring_b [r, π'], lower link [r, π'], upper link [r, π']. Rows are first written
    for global virtual rotations π (δa = δπ × a), then Φ_π' = Φ_π A."""
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


@numba.njit(cache=True, fastmath=True)
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


@numba.njit(cache=True, fastmath=True)
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


@numba.njit(cache=True)
def _lu_solve(A, b, n):
    """Solve A x = b (n x n) by Gaussian elimination with partial pivoting (multibody's
    ``gauss_eliminate`` on [A | b]) and back substitution: x -> b. Returns False if A is singular."""
    Ab = np.empty((n, n + 1))
    Ab[:, :n] = A[:n, :n]
    Ab[:, n] = b[:n]
    ok, _ = gauss_eliminate(Ab, n, n, n + 1)
    if not ok:
        return False
    for i in range(n - 1, -1, -1):
        s = Ab[i, n]
        for m in range(i + 1, n):
            s -= Ab[i, m] * b[m]
        b[i] = s / Ab[i, i]
    return True


@numba.njit(cache=True, fastmath=True)
def accelerations(q, v, forces, alpha, beta, a, ha, sb, cl, cu, mass, inertia, inertia_inv,
                  gravity, acc, lam):
    """Solve eq. 19 for [r̈, ω̇'] (78,) -> acc and λ (72,) -> lam; returns False if singular.

    Baumgarte stabilisation with α, β (0, 0: none): γ <- γ - 2 α Φ̇ - β² Φ (joint rows)."""
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
        leg_blocks(q, v, k, a, ha, sb, cl, cu, B, gamma)
        Al = rotation(q, 7 * bl + 3)
        for i in range(3):
            F[6 * bl + i] -= forces[k] * Al[i, 2]
            F[6 * bu + i] += forces[k] * Al[i, 2]
        if alpha != 0.0 or beta != 0.0:
            leg_residual(q, k, 0.0, a, ha, sb, cl, cu, res)
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


@numba.njit(cache=True)
def leg_lengths_rates(q, v, a, sb):
    """Actuator lengths and rates from ring_b's state: S_k = r_b + A_b s'_k, L = |S_k - a_k|."""
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


@numba.njit(cache=True)
def _derivative(q, v, forces, alpha, beta, a, ha, sb, cl, cu, mass, inertia, inertia_inv,
                gravity, dq, dv):
    """ẏ of the full state: ṙ = v, ṗ = ½ G^T ω', [r̈, ω̇'] from eq. 19; returns (ok, Σ f L̇)."""
    lam = np.empty(72)
    ok = accelerations(q, v, forces, alpha, beta, a, ha, sb, cl, cu, mass, inertia,
                       inertia_inv, gravity, dv, lam)
    for b in range(13):
        o = 7 * b
        for i in range(3):
            dq[o + i] = v[6 * b + i]
        e0, e1, e2, e3 = q[o + 3], q[o + 4], q[o + 5], q[o + 6]
        w0, w1, w2 = v[6 * b + 3], v[6 * b + 4], v[6 * b + 5]
        dq[o + 3] = -0.5 * (e1 * w0 + e2 * w1 + e3 * w2)
        dq[o + 4] = 0.5 * (e0 * w0 + e2 * w2 - e3 * w1)
        dq[o + 5] = 0.5 * (e0 * w1 + e3 * w0 - e1 * w2)
        dq[o + 6] = 0.5 * (e0 * w2 + e1 * w1 - e2 * w0)
    L, Ld = leg_lengths_rates(q, v, a, sb)
    power = 0.0
    for k in range(6):
        power += forces[k] * Ld[k]
    return ok, power


@numba.njit(cache=True)
def rk4_full(q, v, work, forces, dt, alpha, beta, a, ha, sb, cl, cu, mass, inertia,
             inertia_inv, gravity):
    """One RK4 step of all 91 + 78 states (and the actuator work) in place; False if singular."""
    kq = np.empty((4, 91))
    kv = np.empty((4, 78))
    kw = np.empty(4)
    qs = q.copy()
    vs = v.copy()
    coef = (0.5, 0.5, 1.0)
    for s in range(4):
        if s > 0:
            c = coef[s - 1] * dt
            for i in range(91):
                qs[i] = q[i] + c * kq[s - 1, i]
            for i in range(78):
                vs[i] = v[i] + c * kv[s - 1, i]
        ok, p = _derivative(qs, vs, forces, alpha, beta, a, ha, sb, cl, cu, mass, inertia,
                            inertia_inv, gravity, kq[s], kv[s])
        if not ok:
            return False, work
        kw[s] = p
    h6 = dt / 6.0
    for i in range(91):
        q[i] += h6 * (kq[0, i] + 2.0 * kq[1, i] + 2.0 * kq[2, i] + kq[3, i])
    for i in range(78):
        v[i] += h6 * (kv[0, i] + 2.0 * kv[1, i] + 2.0 * kv[2, i] + kv[3, i])
    return True, work + h6 * (kw[0] + 2.0 * kw[1] + 2.0 * kw[2] + kw[3])


@numba.njit(cache=True)
def solve_dependent(q, v, a, ha, sb, cl, cu, tolerance, max_iterations):
    """Partitioned correction: e0 of ring_b from eq. 9, each leg's 14 coordinates by Newton on
    its 12 joint constraints + 2 normalisations, then its 12 velocities from Φ_q v = 0 (eq. 20).

    Returns the Newton iterations summed over legs, or -1 if a leg did not converge."""
    e2 = q[4] ** 2 + q[5] ** 2 + q[6] ** 2
    if e2 >= 1.0:
        return -1
    q[3] = math.copysign(math.sqrt(1.0 - e2), q[3])
    total = 0
    res = np.empty(13)
    Jl = np.empty((13, 21))
    Jn = np.empty((14, 14))
    rn = np.empty(14)
    B = np.empty((13, 18))
    gamma = np.empty(13)
    for k in range(6):
        ol = 7 * (1 + 2 * k)
        ou = 7 * (2 + 2 * k)
        it = 0
        while True:
            leg_residual(q, k, 0.0, a, ha, sb, cl, cu, res)
            for i in range(12):
                rn[i] = res[i]
            rn[12] = q[ol + 3] ** 2 + q[ol + 4] ** 2 + q[ol + 5] ** 2 + q[ol + 6] ** 2 - 1.0
            rn[13] = q[ou + 3] ** 2 + q[ou + 4] ** 2 + q[ou + 5] ** 2 + q[ou + 6] ** 2 - 1.0
            err = 0.0
            for i in range(14):
                err = max(err, abs(rn[i]))
            if err <= tolerance:
                break
            if it >= max_iterations:
                return -1
            leg_jacobian(q, k, a, ha, sb, cl, cu, Jl)
            Jn[:, :] = 0.0
            for i in range(12):
                for j in range(14):
                    Jn[i, j] = Jl[i, 7 + j]
            for j in range(4):
                Jn[12, 3 + j] = 2.0 * q[ol + 3 + j]
                Jn[13, 10 + j] = 2.0 * q[ou + 3 + j]
            for i in range(14):
                rn[i] = -rn[i]
            if not _lu_solve(Jn, rn, 14):
                return -1
            for j in range(7):
                q[ol + j] += rn[j]
                q[ou + j] += rn[7 + j]
            it += 1
        total += it
        leg_blocks(q, v, k, a, ha, sb, cl, cu, B, gamma)
        M = np.ascontiguousarray(B[:12, 6:18])
        x = np.empty(12)
        for r in range(12):
            acc_r = 0.0
            for j in range(6):
                acc_r -= B[r, j] * v[j]
            x[r] = acc_r
        if not _lu_solve(M, x, 12):
            return -1
        bl = 1 + 2 * k
        for j in range(6):
            v[6 * bl + j] = x[j]
            v[6 * bl + 6 + j] = x[6 + j]
    return total


@numba.njit(cache=True)
def rk4_partitioned(q, v, work, forces, dt, a, ha, sb, cl, cu, mass, inertia, inertia_inv,
                    gravity, tolerance, max_iterations):
    """One RK4 step of the independent states (r_b, e_b, ṙ_b, ω'_b, work) with the dependent
    ones solved at every stage. Returns (ok, work, Newton iterations)."""
    y0 = np.empty(12)
    y0[0:3] = q[0:3]
    y0[3:6] = q[4:7]
    y0[6:12] = v[0:6]
    ky = np.empty((4, 12))
    kw = np.empty(4)
    dv = np.empty(78)
    lam = np.empty(72)
    coef = (0.5, 0.5, 1.0)
    newton = 0
    for s in range(4):
        if s > 0:
            c = coef[s - 1] * dt
            y = y0 + c * ky[s - 1]
            q[0:3] = y[0:3]
            q[4:7] = y[3:6]
            v[0:6] = y[6:12]
        it = solve_dependent(q, v, a, ha, sb, cl, cu, tolerance, max_iterations)
        if it < 0:
            return False, work, newton
        newton += it
        if not accelerations(q, v, forces, 0.0, 0.0, a, ha, sb, cl, cu, mass, inertia,
                             inertia_inv, gravity, dv, lam):
            return False, work, newton
        e0, e1, e2, e3 = q[3], q[4], q[5], q[6]
        w0, w1, w2 = v[3], v[4], v[5]
        ky[s, 0:3] = v[0:3]
        ky[s, 3] = 0.5 * (e0 * w0 + e2 * w2 - e3 * w1)
        ky[s, 4] = 0.5 * (e0 * w1 + e3 * w0 - e1 * w2)
        ky[s, 5] = 0.5 * (e0 * w2 + e1 * w1 - e2 * w0)
        ky[s, 6:12] = dv[0:6]
        L, Ld = leg_lengths_rates(q, v, a, sb)
        p = 0.0
        for k in range(6):
            p += forces[k] * Ld[k]
        kw[s] = p
    y = y0 + (dt / 6.0) * (ky[0] + 2.0 * ky[1] + 2.0 * ky[2] + ky[3])
    q[0:3] = y[0:3]
    q[4:7] = y[3:6]
    v[0:6] = y[6:12]
    it = solve_dependent(q, v, a, ha, sb, cl, cu, tolerance, max_iterations)
    if it < 0:
        return False, work, newton
    newton += it
    return True, work + (dt / 6.0) * (kw[0] + 2.0 * kw[1] + 2.0 * kw[2] + kw[3]), newton


@numba.njit(cache=True)
def drift_and_norm(q, a, ha, sb, cl, cu):
    """‖Φ^K‖ (2-norm of the 72 joint constraints) and max_b |p_b^T p_b - 1|."""
    res = np.empty(13)
    s = 0.0
    for k in range(6):
        leg_residual(q, k, 0.0, a, ha, sb, cl, cu, res)
        for i in range(12):
            s += res[i] * res[i]
    n = 0.0
    for b in range(13):
        o = 7 * b + 3
        n = max(n, abs(q[o] ** 2 + q[o + 1] ** 2 + q[o + 2] ** 2 + q[o + 3] ** 2 - 1.0))
    return math.sqrt(s), n


@numba.njit(cache=True)
def observe(q, v, a, ha, sb, cl, cu, mass, inertia, gravity, com_b):
    """Everything reported per output row, in one pass (23,): ring_b position (3), Euler
    parameters (4), lengths (6), length rates (6), ‖Φ^K‖, max |p^T p - 1|, kinetic, potential."""
    out = np.empty(23)
    n = math.sqrt(q[3] ** 2 + q[4] ** 2 + q[5] ** 2 + q[6] ** 2)
    for i in range(4):
        out[3 + i] = q[3 + i] / n
    c = _matvec(rotation(out, 3), (com_b[0], com_b[1], com_b[2]))
    for i in range(3):
        out[i] = q[i] - c[i]
    L, Ld = leg_lengths_rates(q, v, a, sb)
    out[7:13] = L
    out[13:19] = Ld
    drift, norm_error = drift_and_norm(q, a, ha, sb, cl, cu)
    out[19] = drift
    out[20] = norm_error
    kin = 0.0
    pot = 0.0
    for b in range(13):
        o = 6 * b
        w = (v[o + 3], v[o + 4], v[o + 5])
        kin += 0.5 * mass[b] * (v[o] ** 2 + v[o + 1] ** 2 + v[o + 2] ** 2)
        kin += 0.5 * _dot(w, _matvec(inertia[b], w))
        pot -= mass[b] * (gravity[0] * q[7 * b] + gravity[1] * q[7 * b + 1] + gravity[2] * q[7 * b + 2])
    out[21] = kin
    out[22] = pot
    return out


# --- the simulator -----------------------------------------------------------------------------

class MultibodyDynamics:
    """Forward dynamics of one robot (eqs. 19-20), stepped by the caller.

    ``method``: 'baumgarte', 'partitioning' or 'hybrid'. ``alpha``, ``beta`` [1/s]: Baumgarte
    gains. ``correction_tolerance``: the hybrid's drift threshold for a partitioned correction.
    ``newton_tolerance``: residual of the dependent-coordinate Newton solves.
    """

    def __init__(self, geometry: RobotGeometry, method: str = 'hybrid', *, alpha: float = 10.0,
                 beta: float = 10.0, correction_tolerance: float = 1e-10,
                 newton_tolerance: float = 1e-13, max_newton_iterations: int = 20):
        if method not in METHODS:
            raise ValueError(f'method must be one of {METHODS}, got {method!r}')
        for name, value in (('alpha', alpha), ('beta', beta)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value}')
        self.geometry = geometry
        self.method = method
        self.alpha = float(alpha)
        self.beta = float(beta)
        self.correction_tolerance = float(correction_tolerance)
        self.newton_tolerance = float(newton_tolerance)
        self.max_newton_iterations = int(max_newton_iterations)
        self.model = MultibodyModel(geometry)
        m = self.model
        self._kin = (m.a, m.ha, m.sb, m.cl, m.cu)
        mass = np.empty(13)
        inertia = np.empty((13, 3, 3))
        mass[0] = geometry.ring_b_inertia.mass
        inertia[0] = geometry.ring_b_inertia.inertia
        for k in range(6):
            mass[1 + 2 * k] = geometry.lower_link.mass
            inertia[1 + 2 * k] = geometry.lower_link.inertia_tensor()
            mass[2 + 2 * k] = geometry.upper_link.mass
            inertia[2 + 2 * k] = geometry.upper_link.inertia_tensor()
        self.mass = mass
        self.inertia = inertia
        self._dyn = (mass, inertia, np.linalg.inv(inertia),
                     np.ascontiguousarray(geometry.gravity, dtype=float))
        self.corrections = 0
        self.last_step_flops = 0
        self.reset(geometry.home_position, geometry.home_quaternion_xyzw)

    # --- state ---

    def reset(self, position, quaternion_xyzw) -> None:
        """At rest at the pose a_T_b (all joint constraints satisfied, zero velocities)."""
        self.q = self.model.coordinates_from_pose(position, quaternion_xyzw)
        self.v = np.zeros(78)
        self._obs = None
        self.time = 0.0
        self.actuator_work = 0.0
        self.corrections = 0
        self.last_step_flops = 0
        self._energy0 = self.kinetic_energy + self.potential_energy

    def step(self, forces, dt: float) -> None:
        """Advance by dt [s] with actuator forces (6,) [N] held over the step (+ = push apart).

        Raises ValueError for bad input and RuntimeError if the model reaches a singular pose
        (the state is then left at the start of the step)."""
        f = np.ascontiguousarray(forces, dtype=float)
        if f.shape != (6,) or not np.all(np.isfinite(f)):
            raise ValueError(f'forces must be 6 finite numbers [N], got shape {f.shape}')
        dt = float(dt)
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive finite number of seconds, got {dt}')
        q, v = self.q.copy(), self.v.copy()
        if self.method == 'partitioning':
            ok, work, newton = rk4_partitioned(q, v, self.actuator_work, f, dt, *self._kin,
                                               *self._dyn, self.newton_tolerance,
                                               self.max_newton_iterations)
            flops = 4 * EVALUATION_FLOPS + newton * NEWTON_LEG_FLOPS + 5 * 6 * VELOCITY_LEG_FLOPS
        else:
            alpha, beta = self.alpha, self.beta
            ok, work = rk4_full(q, v, self.actuator_work, f, dt, alpha, beta, *self._kin,
                                *self._dyn)
            flops = 4 * EVALUATION_FLOPS + 2 * (91 + 78) * 4
            if alpha != 0.0 or beta != 0.0:
                flops += 4 * 6 * _BAUMGARTE_LEG
            if ok and self.method == 'hybrid':
                drift, norm_error = drift_and_norm(q, *self._kin)
                flops += 6 * FLOPS_LEG_RESIDUAL
                if drift > self.correction_tolerance or norm_error > self.correction_tolerance:
                    newton = solve_dependent(q, v, *self._kin, self.newton_tolerance,
                                             self.max_newton_iterations)
                    ok = newton >= 0
                    flops += max(newton, 0) * NEWTON_LEG_FLOPS + 6 * VELOCITY_LEG_FLOPS
                    self.corrections += 1
        if not ok or not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
            raise RuntimeError(f'dynamics failed at t = {self.time:.6f} s: singular configuration')
        self.q, self.v = q, v
        self._obs = None
        self.actuator_work = float(work)
        self.time += dt
        self.last_step_flops = int(flops)

    def _observation(self) -> np.ndarray:
        if self._obs is None:
            self._obs = observe(self.q, self.v, *self._kin, self.mass, self.inertia,
                                self._dyn[3], self.model.ring_b_com)
        return self._obs

    @property
    def position(self) -> np.ndarray:
        """ring_b's origin in ring_a's frame [m]."""
        return self._observation()[0:3].copy()

    @property
    def quaternion_xyzw(self) -> np.ndarray:
        """ring_b's orientation in ring_a's frame (x, y, z, w), w >= 0."""
        return normalize_quat(euler_parameters_to_quat_xyzw(self._observation()[3:7]))

    @property
    def lengths(self) -> np.ndarray:
        """Actuator lengths [m]."""
        return self._observation()[7:13].copy()

    @property
    def length_rates(self) -> np.ndarray:
        """Actuator velocities [m/s]."""
        return self._observation()[13:19].copy()

    @property
    def constraint_drift(self) -> float:
        """‖Φ^K(q)‖, the 2-norm of the 72 joint constraints."""
        return float(self._observation()[19])

    @property
    def euler_norm_error(self) -> float:
        """max over bodies of |p^T p - 1| (eq. 9)."""
        return float(self._observation()[20])

    @property
    def kinetic_energy(self) -> float:
        """Σ ½ m |ṙ|² + ½ ω'^T J' ω' [J]."""
        return float(self._observation()[21])

    @property
    def potential_energy(self) -> float:
        """-Σ m g·r [J] (zero at ring_a's origin)."""
        return float(self._observation()[22])

    @property
    def energy_balance(self) -> float:
        """Kinetic + potential - actuator work, minus its initial value [J] (0 if exact)."""
        return self.kinetic_energy + self.potential_energy - self.actuator_work - self._energy0

    # --- statics from the Lagrange multipliers ---

    def holding_forces(self, position, quaternion_xyzw) -> np.ndarray:
        """Actuator forces [N] (+ = push apart) that hold ring_b at rest at a pose.

        At rest eq. 19 with the 6 driving constraints (eq. 10) added reads Φ_x^T λ = F^A
        (78 x 78, gravity only); the driving multipliers are the actuator forces: f = -λ_D.
        Raises ValueError at a singular pose."""
        q = self.model.coordinates_from_pose(position, quaternion_xyzw)
        v = np.zeros(78)
        Phi = np.zeros((78, 78))
        B = np.empty((13, 18))
        gamma = np.empty(13)
        for k in range(6):
            leg_blocks(q, v, k, *self._kin, B, gamma)
            cols = np.r_[0:6, 6 * (1 + 2 * k):6 * (1 + 2 * k) + 12]
            Phi[12 * k:12 * k + 12, cols] = B[:12]
            Phi[72 + k, cols] = B[12]
        F = np.zeros(78)
        F.reshape(13, 6)[:, :3] = self.mass[:, None] * self.geometry.gravity
        try:
            lam = np.linalg.solve(Phi.T, F)
        except np.linalg.LinAlgError:
            raise ValueError('singular pose: no finite holding forces') from None
        if not np.all(np.isfinite(lam)) or np.linalg.cond(Phi) > 1e12:
            raise ValueError('singular pose: no finite holding forces')
        return -lam[72:78]


# --- batch runs --------------------------------------------------------------------------------

@dataclass(frozen=True)
class SimulationResult:
    """One row per output step (K rows). Energies [J], times [s], flops per step (model)."""

    t: np.ndarray
    position: np.ndarray
    quaternion_xyzw: np.ndarray
    lengths: np.ndarray
    length_rates: np.ndarray
    forces: np.ndarray
    constraint_drift: np.ndarray
    euler_norm_error: np.ndarray
    energy_balance: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    actuator_work: np.ndarray
    step_flops: np.ndarray
    step_seconds: np.ndarray
    method: str
    dt: float
    corrections: int


def simulate(geometry: RobotGeometry, position, quaternion_xyzw,
             forces: np.ndarray | Callable[[float, MultibodyDynamics], np.ndarray],
             duration: float = 0.5, dt: float = 0.001, method: str = 'hybrid',
             output_every: int = 1, progress: Callable[[float], None] | None = None,
             **options) -> SimulationResult:
    """Start at rest at a pose and integrate for ``duration`` s with steps of ``dt`` s.

    ``forces``: constant (6,) [N] or ``f(t, dyn) -> (6,)`` evaluated at the start of each step
    (held over it). Rows are written at t = 0 and every ``output_every`` steps (and at the end).
    ``progress(fraction)`` is called about 100 times. ``options`` go to MultibodyDynamics.
    """
    pose_arrays(position, quaternion_xyzw)
    for name, value in (('duration', duration), ('dt', dt)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f'{name} must be a positive number of seconds, got {value!r}')
    if dt > duration:
        raise ValueError(f'dt ({dt}) must not exceed duration ({duration})')
    if not (isinstance(output_every, (int, np.integer)) and output_every >= 1):
        raise ValueError(f'output_every must be an integer >= 1, got {output_every!r}')
    if callable(forces):
        force_fn = forces
    else:
        constant = np.asarray(forces, dtype=float)
        if constant.shape != (6,) or not np.all(np.isfinite(constant)):
            raise ValueError(f'forces must be 6 finite numbers [N], got shape {constant.shape}')
        force_fn = lambda t, dyn: constant  # noqa: E731
    dyn = MultibodyDynamics(geometry, method, **options)
    dyn.reset(position, quaternion_xyzw)
    n_steps = int(round(duration / dt))
    rows: dict[str, list] = {key: [] for key in (
        't', 'obs', 'forces', 'actuator_work', 'step_flops', 'step_seconds')}

    def record(f, flops, seconds):
        obs = dyn._observation()
        rows['t'].append(dyn.time)
        rows['obs'].append(obs)
        rows['forces'].append(f)
        rows['actuator_work'].append(dyn.actuator_work)
        rows['step_flops'].append(flops)
        rows['step_seconds'].append(seconds)

    f = _checked_forces(force_fn(0.0, dyn))
    record(f, 0, 0.0)
    report_every = max(1, n_steps // 100)
    flops_acc, seconds_acc = 0, 0.0
    for i in range(1, n_steps + 1):
        f = _checked_forces(force_fn(dyn.time, dyn))
        t0 = time.perf_counter()
        dyn.step(f, dt)
        seconds_acc += time.perf_counter() - t0
        flops_acc += dyn.last_step_flops
        if i % output_every == 0 or i == n_steps:
            k = (i - 1) % output_every + 1
            record(f, flops_acc // k, seconds_acc / k)
            flops_acc, seconds_acc = 0, 0.0
        if progress is not None and (i % report_every == 0 or i == n_steps):
            progress(i / n_steps)
    obs = np.asarray(rows.pop('obs'))
    arrays = {key: np.asarray(val) for key, val in rows.items()}
    work = arrays['actuator_work']
    return SimulationResult(
        **arrays, position=obs[:, 0:3],
        quaternion_xyzw=normalize_quat(euler_parameters_to_quat_xyzw(obs[:, 3:7])),
        lengths=obs[:, 7:13], length_rates=obs[:, 13:19], constraint_drift=obs[:, 19],
        euler_norm_error=obs[:, 20], kinetic=obs[:, 21], potential=obs[:, 22],
        energy_balance=obs[:, 21] + obs[:, 22] - work - dyn._energy0,
        method=method, dt=float(dt), corrections=dyn.corrections)


def _checked_forces(f) -> np.ndarray:
    f = np.asarray(f, dtype=float)
    if f.shape != (6,) or not np.all(np.isfinite(f)):
        raise ValueError(f'forces must be 6 finite numbers [N], got shape {f.shape}')
    return f
