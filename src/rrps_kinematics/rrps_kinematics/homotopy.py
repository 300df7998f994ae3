"""Parameter homotopy for the forward kinematics in Study (soma) coordinates (docs/assembly_modes.md).

Unknowns x = (e, g) in C^8; leg i gives F_i = u.u - L^2 e.e, u = e b - a e + g (eq. 1), with the
Study quadric e.g = 0 and a random chart c.x = 1; parameters one row (a, b, L^2) per leg, (6, 7)
complex. :func:`track` follows a solution from ``P0`` to ``P1`` (gamma trick, RK4 predictor,
Newton corrector), compiled by numba or interpreted (:func:`.backend.jit`).
"""

from __future__ import annotations

import numpy as np

from rrps_kinematics.backend import jit

__all__ = ['study_system', 'track', 'track_all', 'newton_polish',
           'TRACKED', 'FAILED_STEP', 'FAILED_STEPS', 'DIVERGED', 'DIVERGED_FROM']

#: Path status codes of :func:`track`: reached t = 1; the step size fell below ``min_step``;
#: more than ``max_steps`` steps; went to e.e = 0 (the pose r = g e* / e.e to infinity).
TRACKED, FAILED_STEP, FAILED_STEPS, DIVERGED = 0, 1, 2, 3
#: A path with |e.e| / |x|^2 below ``diverged_ratio`` at t >= DIVERGED_FROM is stopped as DIVERGED.
DIVERGED_FROM = 0.99
#: Chord (fixed-Jacobian) Newton iterations of the corrector.
CORRECTOR_ITERATIONS = 6


@jit
def _k_matrix(a0, a1, a2, b0, b1, b2, K):
    """K <- the matrix of e -> e b - a e (quaternions (w, x, y, z), a and b pure)."""
    d0, d1, d2 = b0 - a0, b1 - a1, b2 - a2
    s0, s1, s2 = b0 + a0, b1 + a1, b2 + a2
    K[0, 0], K[0, 1], K[0, 2], K[0, 3] = 0.0, -d0, -d1, -d2
    K[1, 0], K[1, 1], K[1, 2], K[1, 3] = d0, 0.0, s2, -s1
    K[2, 0], K[2, 1], K[2, 2], K[2, 3] = d1, -s2, 0.0, s0
    K[3, 0], K[3, 1], K[3, 2], K[3, 3] = d2, s1, -s0, 0.0


@jit
def study_system(x, P, dP, chart, F, J, Ft, K, dK, u):
    """F <- F(x; P) (8,), J <- dF/dx (8, 8), Ft <- dF/dP . dP (8,) for the system of the module
    docstring; the chart equation is c.x - 1. K, dK (4, 4) and u (4,) are work arrays."""
    ee = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]
    for i in range(6):
        _k_matrix(P[i, 0], P[i, 1], P[i, 2], P[i, 3], P[i, 4], P[i, 5], K)
        _k_matrix(dP[i, 0], dP[i, 1], dP[i, 2], dP[i, 3], dP[i, 4], dP[i, 5], dK)
        m, dm = P[i, 6], dP[i, 6]
        f = 0.0j
        ft = 0.0j
        for r in range(4):
            ur = x[4 + r]
            du = 0.0j
            for k in range(4):
                ur += K[r, k] * x[k]
                du += dK[r, k] * x[k]
            u[r] = ur
            f += ur * ur
            ft += 2.0 * ur * du
        F[i] = f - m * ee
        Ft[i] = ft - dm * ee
        for k in range(4):
            s = 0.0j
            for r in range(4):
                s += K[r, k] * u[r]
            J[i, k] = 2.0 * s - 2.0 * m * x[k]
            J[i, 4 + k] = 2.0 * u[k]
    F[6] = x[0] * x[4] + x[1] * x[5] + x[2] * x[6] + x[3] * x[7]
    F[7] = -1.0
    Ft[6] = 0.0
    Ft[7] = 0.0
    for k in range(4):
        J[6, k] = x[4 + k]
        J[6, 4 + k] = x[k]
    for k in range(8):
        F[7] += chart[k] * x[k]
        J[7, k] = chart[k]


@jit
def _residual(x, P, chart, F, K):
    """F <- F(x; P) only (the corrector's chord iterations)."""
    ee = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]
    for i in range(6):
        _k_matrix(P[i, 0], P[i, 1], P[i, 2], P[i, 3], P[i, 4], P[i, 5], K)
        f = 0.0j
        for r in range(4):
            ur = x[4 + r]
            for k in range(4):
                ur += K[r, k] * x[k]
            f += ur * ur
        F[i] = f - P[i, 6] * ee
    F[6] = x[0] * x[4] + x[1] * x[5] + x[2] * x[6] + x[3] * x[7]
    F[7] = -1.0
    for k in range(8):
        F[7] += chart[k] * x[k]


@jit
def _lu(J, piv):
    """In-place LU factorisation of J (n, n) with partial pivoting (row swaps into piv);
    returns False when a pivot is zero."""
    n = J.shape[0]
    for col in range(n):
        best, p = -1.0, col
        for r in range(col, n):
            v = J[r, col].real * J[r, col].real + J[r, col].imag * J[r, col].imag
            if v > best:
                best, p = v, r
        if best == 0.0:
            return False
        piv[col] = p
        if p != col:
            for k in range(n):
                J[col, k], J[p, k] = J[p, k], J[col, k]
        inv = 1.0 / J[col, col]
        for r in range(col + 1, n):
            f = J[r, col] * inv
            J[r, col] = f
            for k in range(col + 1, n):
                J[r, k] -= f * J[col, k]
    return True


@jit
def _lu_solve(J, piv, rhs, out):
    """out <- J^-1 rhs from the factors of :func:`_lu` (rhs kept)."""
    n = rhs.shape[0]
    for k in range(n):
        out[k] = rhs[k]
    for k in range(n):
        p = piv[k]
        if p != k:
            out[k], out[p] = out[p], out[k]
    for r in range(n):
        s = out[r]
        for k in range(r):
            s -= J[r, k] * out[k]
        out[r] = s
    for r in range(n - 1, -1, -1):
        s = out[r]
        for k in range(r + 1, n):
            s -= J[r, k] * out[k]
        out[r] = s / J[r, r]


@jit
def _solve(J, rhs, out, piv):
    """out <- J^-1 rhs (J overwritten by its factors); False at a zero pivot."""
    if not _lu(J, piv):
        return False
    _lu_solve(J, piv, rhs, out)
    return True


@jit
def _params_at(P0, P1, gamma, t, P, dP):
    """P <- P(t), dP <- dP/dt on the gamma path of the module docstring."""
    den = 1.0 + (gamma - 1.0) * t
    phi = gamma * t / den
    dphi = gamma / (den * den)
    for i in range(6):
        for k in range(7):
            P[i, k] = P0[i, k] + phi * (P1[i, k] - P0[i, k])
            dP[i, k] = dphi * (P1[i, k] - P0[i, k])


@jit
def _velocity(x, P, dP, chart, F, J, Ft, K, dK, u, piv, out):
    """out <- dx/dt = -F_x^-1 F_t; False at a singular Jacobian."""
    study_system(x, P, dP, chart, F, J, Ft, K, dK, u)
    for k in range(8):
        Ft[k] = -Ft[k]
    return _solve(J, Ft, out, piv)


@jit
def _norm(x):
    s = 0.0
    for k in range(x.shape[0]):
        s += x[k].real * x[k].real + x[k].imag * x[k].imag
    return np.sqrt(s)


@jit
def newton_polish(x, P, chart, iterations, tolerance):
    """Newton on F(x; P) = 0 in place, at most ``iterations`` steps, stopping once
    |dx| <= tolerance (1 + |x|); returns the last |dx|."""
    F = np.zeros(8, dtype=np.complex128)
    Ft = np.zeros(8, dtype=np.complex128)
    J = np.zeros((8, 8), dtype=np.complex128)
    zero = np.zeros((6, 7), dtype=np.complex128)
    dx = np.zeros(8, dtype=np.complex128)
    K = np.zeros((4, 4), dtype=np.complex128)
    dK = np.zeros((4, 4), dtype=np.complex128)
    u = np.zeros(4, dtype=np.complex128)
    piv = np.zeros(8, dtype=np.int64)
    size = np.inf
    for _ in range(iterations):
        study_system(x, P, zero, chart, F, J, Ft, K, dK, u)
        if not _solve(J, F, dx, piv):
            return np.inf
        for k in range(8):
            x[k] -= dx[k]
        size = _norm(dx)
        if size <= tolerance * (1.0 + _norm(x)):
            break
    return size


@jit
def track(x, P0, P1, gamma, chart, min_step, max_step, max_steps, tolerance, diverged_ratio):  # noqa: C901 - flat kernel
    """Follow the solution x of F(.; P0) = 0 (in place) to F(.; P1) = 0; returns (status, t
    reached, steps). Corrector: up to CORRECTOR_ITERATIONS chord Newton steps to |dx| <= tolerance (1 + |x|), the
    first at most 0.1 (1 + |x|) (a larger one means the predictor left the path's basin); the
    Jacobian is factored once per corrector (chord iterations)."""
    F = np.zeros(8, dtype=np.complex128)
    Ft = np.zeros(8, dtype=np.complex128)
    J = np.zeros((8, 8), dtype=np.complex128)
    P = np.zeros((6, 7), dtype=np.complex128)
    dP = np.zeros((6, 7), dtype=np.complex128)
    zero = np.zeros((6, 7), dtype=np.complex128)
    k1 = np.zeros(8, dtype=np.complex128)
    k2 = np.zeros(8, dtype=np.complex128)
    k3 = np.zeros(8, dtype=np.complex128)
    k4 = np.zeros(8, dtype=np.complex128)
    y = np.zeros(8, dtype=np.complex128)
    dx = np.zeros(8, dtype=np.complex128)
    K = np.zeros((4, 4), dtype=np.complex128)
    dK = np.zeros((4, 4), dtype=np.complex128)
    u = np.zeros(4, dtype=np.complex128)
    piv = np.zeros(8, dtype=np.int64)
    t = 0.0
    h = max_step / 4.0
    accepted = 0
    steps = 0
    while t < 1.0:
        if steps >= max_steps:
            return FAILED_STEPS, t, steps
        if h < min_step:
            return FAILED_STEP, t, steps
        if t >= DIVERGED_FROM:
            ee = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]
            if abs(ee) < diverged_ratio * _norm(x) ** 2:
                return DIVERGED, t, steps
        steps += 1
        last = h >= 1.0 - t
        if last:
            h = 1.0 - t
        ok = True
        _params_at(P0, P1, gamma, t, P, dP)
        ok = ok and _velocity(x, P, dP, chart, F, J, Ft, K, dK, u, piv, k1)
        for k in range(8):
            y[k] = x[k] + 0.5 * h * k1[k]
        _params_at(P0, P1, gamma, t + 0.5 * h, P, dP)
        ok = ok and _velocity(y, P, dP, chart, F, J, Ft, K, dK, u, piv, k2)
        for k in range(8):
            y[k] = x[k] + 0.5 * h * k2[k]
        ok = ok and _velocity(y, P, dP, chart, F, J, Ft, K, dK, u, piv, k3)
        for k in range(8):
            y[k] = x[k] + h * k3[k]
        _params_at(P0, P1, gamma, t + h, P, dP)
        ok = ok and _velocity(y, P, dP, chart, F, J, Ft, K, dK, u, piv, k4)
        if ok:
            for k in range(8):
                y[k] = x[k] + h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k])
            converged = False
            study_system(y, P, zero, chart, F, J, Ft, K, dK, u)
            factored = _lu(J, piv)
            for it in range(CORRECTOR_ITERATIONS):
                if not factored:
                    break
                if it > 0:
                    _residual(y, P, chart, F, K)
                _lu_solve(J, piv, F, dx)
                for k in range(8):
                    y[k] -= dx[k]
                size, scale = _norm(dx), 1.0 + _norm(y)
                if it == 0 and size > 0.1 * scale:
                    break
                if size <= tolerance * scale:
                    converged = True
                    break
            ok = converged
        if ok:
            for k in range(8):
                x[k] = y[k]
            t = 1.0 if last else t + h
            accepted += 1
            if accepted >= 3:
                h = min(2.0 * h, max_step)
                accepted = 0
        else:
            h *= 0.5
            accepted = 0
    return TRACKED, t, steps


@jit
def track_all(X, P0, P1, gamma, chart, min_step, max_step, max_steps, tolerance, diverged_ratio, status, reached,
              steps):
    """:func:`track` for every row of X (n, 8) in place, then 3 Newton steps at P1 on each
    tracked endpoint; per-path status, t reached and step count into the output arrays."""
    for n in range(X.shape[0]):
        x = X[n]
        s, t, k = track(x, P0, P1, gamma, chart, min_step, max_step, max_steps, tolerance, diverged_ratio)
        status[n], reached[n], steps[n] = s, t, k
        if s == TRACKED:
            newton_polish(x, P1, chart, 3, 1e-15)
