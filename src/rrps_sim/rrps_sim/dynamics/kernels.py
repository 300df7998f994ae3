"""Compiled kernels of the 13-body dynamics: eq. 19 at one state, its multipliers as joint reactions.

F^A holds gravity, the tool wrench on the hub and each actuator force f_k along leg k's axis
(f > 0 pushes the rings apart). Eq. 19 is solved exactly by the robot's structure: each leg's
link accelerations a_l = c - H P a_h follow the hub's (:func:`_leg_solve`), and the hub obeys
(M_h + Σ_k P^T Λ_k P) a_h = F_h - Σ_k P^T w_k, Λ_k = H^T M_l H, w_k = H^T (F_l - M_l c): one 6 x 6
Cholesky solve. Kernels take :class:`~.bundles.DynamicsParameters` and :class:`~.bundles.Workspace`
and allocate nothing.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import gauss_eliminate, leg_residual_with_rotations, rotation_into
from rrps_sim.dynamics.constraints import (
    cross3,
    leg_blocks_with_rotations,
    matvec3,
    ring_b_grounded_residual,
)

__all__ = ['accelerations', 'applied_forces', 'lu_solve', 'multipliers', 'reactions_into']


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
def _leg_solve(B, gamma, r0, m, K, Y):
    """Solve B_l Y = [E | γ] (B_l: leg rows 0-11 on the link columns 6-17): Y = [H | c]; False if B_l
    is singular. Rows 0-5 (eqs. 3-4) give the link translations from their rotations, which leaves a
    6 x 6 system (partial pivoting); y = [r_l, π_l, r_u, π_u]."""
    for i in range(6):
        r = 6 + i
        for j in range(3):
            K[i, j] = B[r, 9 + j]
            K[i, 3 + j] = B[r, 15 + j]
        for c in range(m):
            K[i, 6 + c] = 1.0 if r == r0 + c else 0.0
        K[i, 6 + m] = gamma[r]
    for r in (9, 10):
        i = r - 6
        e0, e1, e2 = B[r, 12], B[r, 13], B[r, 14]
        for j in range(3):
            K[i, j] += e0 * B[3, 9 + j] + e1 * B[4, 9 + j] + e2 * B[5, 9 + j]
            K[i, 3 + j] -= e0 * B[0, 15 + j] + e1 * B[1, 15 + j] + e2 * B[2, 15 + j]
        for c in range(m):                  # + e · (b_3:6 - b_0:3) of a unit column
            u = r0 + c
            if u < 6:
                K[i, 6 + c] += B[r, 12 + u - 3] if u >= 3 else -B[r, 12 + u]
        K[i, 6 + m] += (e0 * (gamma[3] - gamma[0]) + e1 * (gamma[4] - gamma[1])
                        + e2 * (gamma[5] - gamma[2]))
    ok, _ = gauss_eliminate(K, 6, 6, 7 + m)
    if not ok:
        return False
    for c in range(m + 1):
        rhs = 6 + c
        for i in range(5, -1, -1):
            s = K[i, rhs]
            for j in range(i + 1, 6):
                s -= K[i, j] * K[j, rhs]
            K[i, rhs] = s / K[i, i]
        for i in range(3):
            Y[3 + i, c] = K[i, rhs]
            Y[9 + i, c] = K[3 + i, rhs]
            bl = gamma[3 + i] if c == m else (1.0 if r0 + c == 3 + i else 0.0)
            bu = gamma[i] if c == m else (1.0 if r0 + c == i else 0.0)
            Y[i, c] = bl - (B[3 + i, 9] * K[0, rhs] + B[3 + i, 10] * K[1, rhs] + B[3 + i, 11] * K[2, rhs])
            Y[6 + i, c] = bu - (B[i, 15] * K[3, rhs] + B[i, 16] * K[4, rhs] + B[i, 17] * K[5, rhs])
    return True


@jit(fastmath=True)
def applied_forces(q, v, params, A, F):
    """F^A (78,) without the actuators: gravity, gyroscopic terms and the tool wrench on the hub
    (forces in the ground's frame, moments in the body frames); A <- the 13 rotations."""
    mass, inertia, gravity = params.mass, params.inertia, params.gravity
    for b in range(13):
        rotation_into(q, 7 * b + 3, A[b])
        w = (v[6 * b + 3], v[6 * b + 4], v[6 * b + 5])
        gyro = cross3(w, matvec3(inertia[b], w))
        for i in range(3):
            F[6 * b + i] = mass[b] * gravity[i]
            F[6 * b + 3 + i] = -gyro[i]
    tw, tp, Ah = params.tool_wrench, params.tool_point, A[0]
    f = matvec3(Ah, (tw[2, 0], tw[2, 1], tw[2, 2]))
    f_body = (tw[2, 0] + Ah[0, 0] * tw[0, 0] + Ah[1, 0] * tw[0, 1] + Ah[2, 0] * tw[0, 2],
              tw[2, 1] + Ah[0, 1] * tw[0, 0] + Ah[1, 1] * tw[0, 1] + Ah[2, 1] * tw[0, 2],
              tw[2, 2] + Ah[0, 2] * tw[0, 0] + Ah[1, 2] * tw[0, 1] + Ah[2, 2] * tw[0, 2])
    arm = cross3(tp, f_body)
    for i in range(3):
        F[i] += tw[0, i] + f[i]
        F[3 + i] += (arm[i] + tw[3, i] + Ah[0, i] * tw[1, 0] + Ah[1, i] * tw[1, 1]
                     + Ah[2, i] * tw[1, 2])


@jit(fastmath=True)
def accelerations(q, v, forces, alpha, beta, params, ws, acc):  # noqa: C901 - a compiled kernel: flat loops for numba
    """Solve eq. 19 for [r̈, ω̇'] (78,) -> acc; returns False if singular.

    Baumgarte stabilisation with α, β (0, 0: none): γ <- γ - 2 α Φ̇ - β² Φ (joint rows). Leaves
    the body rotations, F and each leg's blocks in ``ws`` (for :func:`multipliers`). The hub
    rows' P is [-I | Y] on the point rows and, with ring_b grounded, [0 | z^T] on the universal
    joint's dot-1 row."""
    joints, mass, inertia, support = params.joints, params.mass, params.inertia, params.support
    m = 3 + support
    r0 = 3 * support
    A = ws.rotations
    F = ws.forces
    applied_forces(q, v, params, A, F)
    S = ws.ring
    for i in range(6):
        for j in range(6):
            S[i, j] = 0.0
        S[i, 6] = F[i]
    for i in range(3):
        S[i, i] = mass[0]
        for j in range(3):
            S[3 + i, 3 + j] = inertia[0, i, j]
    MH = ws.effective
    LY = ws.coupling
    for k in range(6):
        bl = 1 + 2 * k
        bu = 2 + 2 * k
        B = ws.blocks[k]
        gamma = ws.gamma[k]
        leg_blocks_with_rotations(q, v, k, joints, support, A[0], A[bl], A[bu], B, gamma)
        for i in range(3):
            F[6 * bl + i] -= forces[k] * A[bl, i, 2]
            F[6 * bu + i] += forces[k] * A[bl, i, 2]
        if alpha != 0.0 or beta != 0.0:
            res = ws.residual
            leg_residual_with_rotations(q, k, 0.0, joints, A[0], A[bl], A[bu], res)
            if support == 1:
                ring_b_grounded_residual(q, k, joints, A[0], A[bl], A[bu], res)
            for r in range(12):
                phidot = 0.0
                for j in range(6):
                    phidot += (B[r, j] * v[j] + B[r, 6 + j] * v[6 * bl + j]
                               + B[r, 12 + j] * v[6 * bu + j])
                gamma[r] -= 2.0 * alpha * phidot + beta * beta * res[r]
        H = ws.response[k]
        if not _leg_solve(B, gamma, r0, m, ws.reduced, H):
            return False
        # M_l [H | c]: the links' masses and inertias J' on [r_l, π_l, r_u, π_u]
        for col in range(m + 1):
            for i in range(3):
                MH[i, col] = mass[bl] * H[i, col]
                MH[6 + i, col] = mass[bu] * H[6 + i, col]
                MH[3 + i, col] = (inertia[bl, i, 0] * H[3, col] + inertia[bl, i, 1] * H[4, col]
                                  + inertia[bl, i, 2] * H[5, col])
                MH[9 + i, col] = (inertia[bu, i, 0] * H[9, col] + inertia[bu, i, 1] * H[10, col]
                                  + inertia[bu, i, 2] * H[11, col])
        # Λ = H^T M_l H and w = H^T (F_l - M_l c) over the hub rows (a fourth, the dot-1 row, with
        # ring_b grounded; zero otherwise), then S += P^T Λ P, t -= P^T w
        L00 = L01 = L02 = L03 = L11 = L12 = L13 = L22 = L23 = L33 = 0.0
        w0 = w1 = w2 = w3 = 0.0
        for r in range(12):
            fm = (F[6 * bl + r] if r < 6 else F[6 * bu + r - 6]) - MH[r, m]
            h0, h1, h2 = H[r, 0], H[r, 1], H[r, 2]
            L00 += h0 * MH[r, 0]
            L01 += h0 * MH[r, 1]
            L02 += h0 * MH[r, 2]
            L11 += h1 * MH[r, 1]
            L12 += h1 * MH[r, 2]
            L22 += h2 * MH[r, 2]
            w0 += h0 * fm
            w1 += h1 * fm
            w2 += h2 * fm
            if m == 4:
                h3 = H[r, 3]
                L03 += h0 * MH[r, 3]
                L13 += h1 * MH[r, 3]
                L23 += h2 * MH[r, 3]
                L33 += h3 * MH[r, 3]
                w3 += h3 * fm
        lam = ((L00, L01, L02, L03), (L01, L11, L12, L13), (L02, L12, L22, L23), (L03, L13, L23, L33))
        w = (w0, w1, w2, w3)
        P = ((B[r0, 3], B[r0, 4], B[r0, 5]), (B[r0 + 1, 3], B[r0 + 1, 4], B[r0 + 1, 5]),
             (B[r0 + 2, 3], B[r0 + 2, 4], B[r0 + 2, 5]),
             (B[6, 3], B[6, 4], B[6, 5]) if m == 4 else (0.0, 0.0, 0.0))
        for a in range(4):
            for j in range(3):
                LY[a, j] = lam[a][0] * P[0][j] + lam[a][1] * P[1][j] + lam[a][2] * P[2][j] + lam[a][3] * P[3][j]
        for i in range(3):
            S[i, 6] += w[i]
            S[3 + i, 6] -= P[0][i] * w0 + P[1][i] * w1 + P[2][i] * w2 + P[3][i] * w3
            for j in range(3):
                S[i, j] += lam[i][j]
                S[i, 3 + j] -= LY[i, j]
                S[3 + j, i] -= LY[i, j]
                S[3 + i, 3 + j] += (P[0][i] * LY[0, j] + P[1][i] * LY[1, j] + P[2][i] * LY[2, j]
                                    + P[3][i] * LY[3, j])
    if not _cholesky(S, 6):
        return False
    _cholesky_solve(S, S[:, 6:7], 6, 1)
    for i in range(6):
        acc[i] = S[i, 6]
    for k in range(6):
        B = ws.blocks[k]
        H = ws.response[k]
        # P a_h = -ṙ_h + Y ω̇'_h on the point rows (and z^T ω̇'_h on the dot-1 row), a_l = c - H P a_h
        z0 = -acc[0] + B[r0, 3] * acc[3] + B[r0, 4] * acc[4] + B[r0, 5] * acc[5]
        z1 = -acc[1] + B[r0 + 1, 3] * acc[3] + B[r0 + 1, 4] * acc[4] + B[r0 + 1, 5] * acc[5]
        z2 = -acc[2] + B[r0 + 2, 3] * acc[3] + B[r0 + 2, 4] * acc[4] + B[r0 + 2, 5] * acc[5]
        o = 6 * (1 + 2 * k)
        if m == 3:
            for r in range(12):
                acc[o + r] = H[r, 3] - (H[r, 0] * z0 + H[r, 1] * z1 + H[r, 2] * z2)
        else:
            z3 = B[6, 3] * acc[3] + B[6, 4] * acc[4] + B[6, 5] * acc[5]
            for r in range(12):
                acc[o + r] = H[r, 4] - (H[r, 0] * z0 + H[r, 1] * z1 + H[r, 2] * z2 + H[r, 3] * z3)
    return True


@jit
def lu_solve(A, b, n):
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


@jit
def multipliers(params, ws, acc, lam):
    """The joint multipliers λ (72,) of eq. 19 -> lam, from the last :func:`accelerations` call
    (its ``ws`` and ``acc``): per leg B_l^T λ_k = F_l - M_l a_l. Returns False if singular."""
    mass, inertia = params.mass, params.inertia
    Bt = np.empty((12, 12))
    rhs = np.empty(12)
    for k in range(6):
        B = ws.blocks[k]
        for r in range(12):
            for m in range(12):
                Bt[m, r] = B[r, 6 + m]
        for half in range(2):
            body = 1 + 2 * k + half
            o = 6 * body
            for i in range(3):
                rhs[6 * half + i] = ws.forces[o + i] - mass[body] * acc[o + i]
                rhs[6 * half + 3 + i] = ws.forces[o + 3 + i] - (
                    inertia[body, i, 0] * acc[o + 3] + inertia[body, i, 1] * acc[o + 4]
                    + inertia[body, i, 2] * acc[o + 5])
        if not lu_solve(Bt, rhs, 12):
            return False
        for r in range(12):
            lam[12 * k + r] = rhs[r]
    return True


@jit
def reactions_into(q, v, forces, params, ws, out, row):
    """The joint reactions of a state (:class:`~.bundles.Reactions`) from the multipliers of
    eq. 19 into row ``row`` of ``out``: -λ of the spherical rows (eq. 3) on the upper link,
    of the universal point rows (eq. 4) on the lower link, and the torque -λ_6 (g_l × h) of the
    universal joint's dot-1 row (eq. 5). Returns False if eq. 19 is singular there."""
    acc = np.empty(78)
    lam = np.empty(72)
    if not accelerations(q, v, forces, 0.0, 0.0, params, ws, acc) or not multipliers(params, ws, acc, lam):
        return False
    ha = params.joints.ha
    for k in range(6):
        o = 12 * k
        Al = ws.rotations[1 + 2 * k]
        h = (ha[k, 0], ha[k, 1], ha[k, 2])
        if params.support == 1:
            h = matvec3(ws.rotations[0], h)
        torque = cross3((Al[0, 1], Al[1, 1], Al[2, 1]), h)
        for i in range(3):
            out.spherical[row, k, i] = -lam[o + i]
            out.universal[row, k, i] = -lam[o + 3 + i]
            out.universal_torque[row, k, i] = -lam[o + 6] * torque[i]
    return True
