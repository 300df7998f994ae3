"""The three integrators of the DAE (eqs. 19-20), compiled: classical RK4 on the index-1
accelerations, one step of the user's dt.

* ``baumgarte``: constraint stabilisation, γ <- γ - 2 α Φ̇ - β² Φ, all 91 + 78 states integrated
  (:func:`rk4_full`).
* ``partitioning``: coordinate partitioning (:func:`rk4_partitioned`). Independent coordinates:
  ring_b's com position and Euler vector part (e1, e2, e3) with their velocities (ṙ_b, ω'_b);
  dependent: ring_b's e0 (eq. 9) and the 84 leg-link coordinates, solved by Newton-Raphson on
  the constraints (eqs. 3-9, per leg: 14 equations in 14 unknowns), the dependent velocities
  from Φ_q v = 0 (eq. 20) (:func:`solve_dependent`).
* ``hybrid``: the paper's choice: Baumgarte-stabilised integration of all states and, whenever
  the drift ‖Φ‖ or an Euler-parameter norm error exceeds a tolerance, the partitioned
  correction (:func:`solve_dependent`).

Euler parameters follow ṗ = ½ G^T ω' (G = [-e, -ẽ + e0 I]). The actuator work ∫ Σ f_k L̇_k dt is
integrated with the states, for the energy balance.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import gauss_eliminate, leg_jacobian, leg_residual

from .kernels import accelerations, leg_blocks, leg_lengths_rates

__all__ = ['METHODS', 'NOT_CONVERGED', 'SINGULAR', 'rk4_full', 'rk4_partitioned',
           'solve_dependent']

METHODS = ('baumgarte', 'partitioning', 'hybrid')
#: Failure codes of the partitioned solves (negative, as no iteration count is).
NOT_CONVERGED = -1
SINGULAR = -2


@jit
def _derivative(q, v, forces, alpha, beta, params, dq, dv):
    """ẏ of the full state: ṙ = v, ṗ = ½ G^T ω', [r̈, ω̇'] from eq. 19; returns (ok, Σ f L̇)."""
    lam = np.empty(72)
    ok = accelerations(q, v, forces, alpha, beta, params, dv, lam)
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
    L, Ld = leg_lengths_rates(q, v, params.joints)
    power = 0.0
    for k in range(6):
        power += forces[k] * Ld[k]
    return ok, power


@jit
def rk4_full(q, v, work, forces, dt, alpha, beta, params):
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
        ok, p = _derivative(qs, vs, forces, alpha, beta, params, kq[s], kv[s])
        if not ok:
            return False, work
        kw[s] = p
    h6 = dt / 6.0
    for i in range(91):
        q[i] += h6 * (kq[0, i] + 2.0 * kq[1, i] + 2.0 * kq[2, i] + kq[3, i])
    for i in range(78):
        v[i] += h6 * (kv[0, i] + 2.0 * kv[1, i] + 2.0 * kv[2, i] + kv[3, i])
    return True, work + h6 * (kw[0] + 2.0 * kw[1] + 2.0 * kw[2] + kw[3])


@jit
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



@jit
def solve_dependent(q, v, joints, tolerance, max_iterations):
    """Partitioned correction: e0 of ring_b from eq. 9, each leg's 14 coordinates by Newton on
    its 12 joint constraints + 2 normalisations, then its 12 velocities from Φ_q v = 0 (eq. 20).

    Returns the Newton iterations summed over legs, or NOT_CONVERGED (a leg's Newton solve did not
    converge, or ring_b's |e| >= 1) or SINGULAR (a leg's Jacobian is singular)."""
    e2 = q[4] ** 2 + q[5] ** 2 + q[6] ** 2
    if e2 >= 1.0:
        return NOT_CONVERGED
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
            leg_residual(q, k, 0.0, joints, res)
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
                return NOT_CONVERGED
            leg_jacobian(q, k, joints, Jl)
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
                return SINGULAR
            for j in range(7):
                q[ol + j] += rn[j]
                q[ou + j] += rn[7 + j]
            it += 1
        total += it
        leg_blocks(q, v, k, joints, B, gamma)
        M = np.ascontiguousarray(B[:12, 6:18])
        x = np.empty(12)
        for r in range(12):
            acc_r = 0.0
            for j in range(6):
                acc_r -= B[r, j] * v[j]
            x[r] = acc_r
        if not _lu_solve(M, x, 12):
            return SINGULAR
        bl = 1 + 2 * k
        for j in range(6):
            v[6 * bl + j] = x[j]
            v[6 * bl + 6 + j] = x[6 + j]
    return total


@jit
def rk4_partitioned(q, v, work, forces, dt, params, tolerance, max_iterations):
    """One RK4 step of the independent states (r_b, e_b, ṙ_b, ω'_b, work) with the dependent
    ones solved at every stage. Returns (status, work, Newton iterations), status 0 or the code
    of :func:`solve_dependent` or SINGULAR (eq. 19 singular)."""
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
        it = solve_dependent(q, v, params.joints, tolerance, max_iterations)
        if it < 0:
            return it, work, newton
        newton += it
        if not accelerations(q, v, forces, 0.0, 0.0, params, dv, lam):
            return SINGULAR, work, newton
        e0, e1, e2, e3 = q[3], q[4], q[5], q[6]
        w0, w1, w2 = v[3], v[4], v[5]
        ky[s, 0:3] = v[0:3]
        ky[s, 3] = 0.5 * (e0 * w0 + e2 * w2 - e3 * w1)
        ky[s, 4] = 0.5 * (e0 * w1 + e3 * w0 - e1 * w2)
        ky[s, 5] = 0.5 * (e0 * w2 + e1 * w1 - e2 * w0)
        ky[s, 6:12] = dv[0:6]
        L, Ld = leg_lengths_rates(q, v, params.joints)
        p = 0.0
        for k in range(6):
            p += forces[k] * Ld[k]
        kw[s] = p
    y = y0 + (dt / 6.0) * (ky[0] + 2.0 * ky[1] + 2.0 * ky[2] + ky[3])
    q[0:3] = y[0:3]
    q[4:7] = y[3:6]
    v[0:6] = y[6:12]
    it = solve_dependent(q, v, params.joints, tolerance, max_iterations)
    if it < 0:
        return it, work, newton
    newton += it
    return 0, work + (dt / 6.0) * (kw[0] + 2.0 * kw[1] + 2.0 * kw[2] + kw[3]), newton
