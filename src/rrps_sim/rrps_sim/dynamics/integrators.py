"""The three integrators of the DAE (eqs. 19-20), compiled: RK4 on the index-1 accelerations.

``baumgarte`` stabilises γ with all 91 + 78 states integrated (:func:`rk4_full`);
``partitioning`` integrates the hub's coordinates and solves the dependent ones by Newton-Raphson
(eqs. 3-9) and eq. 20 (:func:`rk4_partitioned`, :func:`solve_dependent`); ``hybrid``, the paper's
choice, is Baumgarte with a partitioned correction when the drift exceeds a tolerance.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import JointGeometry, leg_jacobian, leg_residual_with_rotations, rotation, rotation_into
from rrps_sim.dynamics.bundles import workspace
from rrps_sim.dynamics.constraints import leg_blocks, matvec3, ring_b_grounded_residual
from rrps_sim.dynamics.kernels import accelerations, lu_solve, reactions_into
from rrps_sim.dynamics.observation import actuator_power, drift_and_norm, observe_into

__all__ = ['METHODS', 'NOT_CONVERGED', 'SINGULAR', 'rk4_full', 'rk4_partitioned', 'run',
           'solve_dependent', 'step']

METHODS = ('baumgarte', 'partitioning', 'hybrid')
BAUMGARTE, PARTITIONING, HYBRID = 0, 1, 2
#: Failure codes of a step (negative, as no iteration count is).
NOT_CONVERGED = -1
SINGULAR = -2


@jit(fastmath=True)
def _derivative(q, v, forces, alpha, beta, params, ws, dq, dv):
    """ẏ of the full state: ṙ = v, ṗ = ½ G^T ω', [r̈, ω̇'] from eq. 19; returns (ok, Σ f L̇)."""
    if not accelerations(q, v, forces, alpha, beta, params, ws, dv):
        return False, 0.0
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
    return True, actuator_power(q, v, forces, params.joints, ws.rotations[0])


@jit(fastmath=True)
def rk4_full(q, v, work, forces, dt, alpha, beta, params, ws):
    """One RK4 step of all 91 + 78 states (and the actuator work) in place; (ok, work), ok False
    if eq. 19 is singular at a stage (q, v are then left as they were)."""
    kq, kv, kw, qs, vs = ws.kq, ws.kv, ws.kw, ws.qs, ws.vs
    qs[:] = q
    vs[:] = v
    for s in range(4):
        if s > 0:
            c = dt if s == 3 else 0.5 * dt
            for i in range(91):
                qs[i] = q[i] + c * kq[s - 1, i]
            for i in range(78):
                vs[i] = v[i] + c * kv[s - 1, i]
        ok, p = _derivative(qs, vs, forces, alpha, beta, params, ws, kq[s], kv[s])
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
def _newton_joints(q, params):
    """The joint data whose link Jacobian (:func:`~rrps_kinematics.multibody.leg_jacobian`, its
    columns 7-20) is that of the constraints of :mod:`.constraints` with the hub held still: the
    universal axes as they stand, fixed (ring_a grounded) or turned by the hub (ring_b grounded)."""
    joints = params.joints
    Ah = rotation(q, 3)
    ha = np.empty((6, 3))
    for k in range(6):
        h = (joints.ha[k, 0], joints.ha[k, 1], joints.ha[k, 2])
        if params.support == 1:
            h = matvec3(Ah, h)
        for i in range(3):
            ha[k, i] = h[i]
    return JointGeometry(joints.a, ha, joints.sb, joints.cl, joints.cu)


@jit
def solve_dependent(q, v, params, tolerance, max_iterations):  # noqa: C901 - a compiled kernel: flat loops for numba
    """Partitioned correction: e0 of the hub from eq. 9, each leg's 14 coordinates by Newton on
    its 12 joint constraints + 2 normalisations, then its 12 velocities from Φ_q v = 0 (eq. 20).

    Returns the Newton iterations summed over legs, or NOT_CONVERGED (a leg's Newton solve did not
    converge, or the hub's |e| >= 1) or SINGULAR (a leg's Jacobian is singular)."""
    e2 = q[4] ** 2 + q[5] ** 2 + q[6] ** 2
    if e2 >= 1.0:
        return NOT_CONVERGED
    q[3] = math.copysign(math.sqrt(1.0 - e2), q[3])
    joints, support = params.joints, params.support
    newton_joints = _newton_joints(q, params)
    total = 0
    res = np.empty(13)
    Jl = np.empty((13, 21))
    Jn = np.empty((14, 14))
    rn = np.empty(14)
    B = np.empty((13, 18))
    gamma = np.empty(13)
    Ah = rotation(q, 3)
    Al = np.empty((3, 3))
    Au = np.empty((3, 3))
    for k in range(6):
        ol = 7 * (1 + 2 * k)
        ou = 7 * (2 + 2 * k)
        it = 0
        while True:
            rotation_into(q, ol + 3, Al)
            rotation_into(q, ou + 3, Au)
            leg_residual_with_rotations(q, k, 0.0, joints, Ah, Al, Au, res)
            if support == 1:
                ring_b_grounded_residual(q, k, joints, Ah, Al, Au, res)
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
            leg_jacobian(q, k, newton_joints, Jl)
            Jn[:, :] = 0.0
            for i in range(12):
                for j in range(14):
                    Jn[i, j] = Jl[i, 7 + j]
            for j in range(4):
                Jn[12, 3 + j] = 2.0 * q[ol + 3 + j]
                Jn[13, 10 + j] = 2.0 * q[ou + 3 + j]
            for i in range(14):
                rn[i] = -rn[i]
            if not lu_solve(Jn, rn, 14):
                return SINGULAR
            for j in range(7):
                q[ol + j] += rn[j]
                q[ou + j] += rn[7 + j]
            it += 1
        total += it
        leg_blocks(q, v, k, joints, support, B, gamma)
        M = np.ascontiguousarray(B[:12, 6:18])
        x = np.empty(12)
        for r in range(12):
            acc_r = 0.0
            for j in range(6):
                acc_r -= B[r, j] * v[j]
            x[r] = acc_r
        if not lu_solve(M, x, 12):
            return SINGULAR
        bl = 1 + 2 * k
        for j in range(6):
            v[6 * bl + j] = x[j]
            v[6 * bl + 6 + j] = x[6 + j]
    return total


@jit
def rk4_partitioned(q, v, work, forces, dt, params, tolerance, max_iterations, ws):
    """One RK4 step of the independent states (r_b, e_b, ṙ_b, ω'_b, work) with the dependent
    ones solved at every stage. Returns (status, work, Newton iterations): status 0, or the
    failure code of :func:`solve_dependent` or SINGULAR (eq. 19 singular)."""
    y0, ky, kw, dv = ws.y0, ws.ky, ws.kw, ws.kv[0]
    y0[0:3] = q[0:3]
    y0[3:6] = q[4:7]
    y0[6:12] = v[0:6]
    newton = 0
    for s in range(4):
        if s > 0:
            c = dt if s == 3 else 0.5 * dt
            for i in range(3):
                q[i] = y0[i] + c * ky[s - 1, i]
                q[4 + i] = y0[3 + i] + c * ky[s - 1, 3 + i]
            for i in range(6):
                v[i] = y0[6 + i] + c * ky[s - 1, 6 + i]
        it = solve_dependent(q, v, params, tolerance, max_iterations)
        if it < 0:
            return it, work, newton
        newton += it
        if not accelerations(q, v, forces, 0.0, 0.0, params, ws, dv):
            return SINGULAR, work, newton
        e0, e1, e2, e3 = q[3], q[4], q[5], q[6]
        w0, w1, w2 = v[3], v[4], v[5]
        ky[s, 0:3] = v[0:3]
        ky[s, 3] = 0.5 * (e0 * w0 + e2 * w2 - e3 * w1)
        ky[s, 4] = 0.5 * (e0 * w1 + e3 * w0 - e1 * w2)
        ky[s, 5] = 0.5 * (e0 * w2 + e1 * w1 - e2 * w0)
        ky[s, 6:12] = dv[0:6]
        kw[s] = actuator_power(q, v, forces, params.joints, ws.rotations[0])
    h6 = dt / 6.0
    for i in range(3):
        q[i] = y0[i] + h6 * (ky[0, i] + 2.0 * ky[1, i] + 2.0 * ky[2, i] + ky[3, i])
        q[4 + i] = y0[3 + i] + h6 * (ky[0, 3 + i] + 2.0 * ky[1, 3 + i] + 2.0 * ky[2, 3 + i]
                                     + ky[3, 3 + i])
    for i in range(6):
        v[i] = y0[6 + i] + h6 * (ky[0, 6 + i] + 2.0 * ky[1, 6 + i] + 2.0 * ky[2, 6 + i]
                                 + ky[3, 6 + i])
    it = solve_dependent(q, v, params, tolerance, max_iterations)
    if it < 0:
        return it, work, newton
    return 0, work + h6 * (kw[0] + 2.0 * kw[1] + 2.0 * kw[2] + kw[3]), newton + it


@jit
def step(q, v, work, forces, dt, method, alpha, beta, correction_tolerance, newton_tolerance,
         max_iterations, params, buffer):
    """One step of ``method`` (BAUMGARTE, PARTITIONING or HYBRID) in place, compiled whole, in the
    workspace ``buffer`` (:func:`~rrps_sim.dynamics.bundles.new_workspace`).

    Returns (status, work, Newton iterations, corrected): status 0, NOT_CONVERGED or SINGULAR
    (then q, v are left as they were); ``corrected``: the hybrid made a partitioned correction
    (whenever ‖Φ^K‖ or an Euler-parameter norm error exceeds ``correction_tolerance``)."""
    return _step(q, v, work, forces, dt, method, alpha, beta, correction_tolerance,
                 newton_tolerance, max_iterations, params, workspace(buffer))


@jit
def _step(q, v, work, forces, dt, method, alpha, beta, correction_tolerance, newton_tolerance,
          max_iterations, params, ws):
    """:func:`step` in the workspace views ``ws``."""
    ws.q0[:] = q
    ws.v0[:] = v
    newton = 0
    corrected = False
    if method == PARTITIONING:
        status, new_work, newton = rk4_partitioned(q, v, work, forces, dt, params,
                                                   newton_tolerance, max_iterations, ws)
    else:
        ok, new_work = rk4_full(q, v, work, forces, dt, alpha, beta, params, ws)
        status = 0 if ok else SINGULAR
        if ok and method == HYBRID:
            drift, norm_error = drift_and_norm(q, params, ws)
            if drift > correction_tolerance or norm_error > correction_tolerance:
                corrected = True
                it = solve_dependent(q, v, params, newton_tolerance, max_iterations)
                if it < 0:
                    status = it
                else:
                    newton = it
    if status == 0:
        for i in range(91):
            if not math.isfinite(q[i]):
                status = SINGULAR
        for i in range(78):
            if not math.isfinite(v[i]):
                status = SINGULAR
    if status != 0:
        q[:] = ws.q0
        v[:] = ws.v0
        return status, work, newton, corrected
    return 0, new_work, newton, corrected


@jit
def run(q, v, work, forces, dt, first, last, output_every, method, alpha, beta,
        correction_tolerance, newton_tolerance, max_iterations, params, buffer, observed, work_out,
        newton_out, corrected_out, with_reactions, reactions_out):
    """Steps ``first`` .. ``last`` - 1 of a constant-force run, in place, recording every
    ``output_every`` steps and after the last into ``observed``, ``work_out`` and ``reactions_out``.
    Returns (status, work, step): status 0 and ``last``, or the failure code and the failing step
    (the state is then that before it)."""
    n_steps = len(newton_out)
    ws = workspace(buffer)
    for i in range(first, last):
        status, work, newton, corrected = _step(q, v, work, forces, dt, method, alpha, beta,
                                                correction_tolerance, newton_tolerance,
                                                max_iterations, params, ws)
        newton_out[i] = newton
        corrected_out[i] = corrected
        if status != 0:
            return status, work, i
        if (i + 1) % output_every == 0 or i + 1 == n_steps:
            row = (i + output_every) // output_every
            observe_into(q, v, params, ws, observed, row)
            work_out[row] = work
            if with_reactions and not reactions_into(q, v, forces, params, ws, reactions_out, row):
                return SINGULAR, work, i
    return 0, work, last
