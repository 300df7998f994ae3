#!/usr/bin/env python3
"""Benchmark of the multibody dynamics and the 91-coordinate direct kinematics (issue 3).

    python benchmarks/dynamics.py [--robot pole_climber] [--duration 0.5] [--dt 0.001] [--repeats 3]

DAE: the paper's run, constant actuator forces from rest for ``--duration`` s at ``--dt`` steps
(RK4), for the three integrators, timed end to end through ``simulate`` (recording every step).
Baseline in the same run: the same RK4 on the same equations with eq. 19 assembled as one dense
150 x 150 matrix [M Φ^T; Φ 0] and solved by LAPACK (np.linalg.solve) at every evaluation,
instead of the structured per-leg Cholesky + Woodbury solve compiled with numba.
DK: Newton-Raphson on the 91 coordinates along Figure 6's climb (11 phases, seeded by the
previous phase): the structured per-leg elimination (default) vs SuperLU on the sparse Φ_q and
dense LAPACK LU, with the 6-DOF pose-level FK for scale.
Times are the best of ``--repeats`` (the 2 cores are shared). Targets: DAE >= 5x faster than
real time; multibody DK <= 2 ms per solve.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import numpy as np

from rrps_kinematics import forward_kinematics, inverse_kinematics, load_robot
from rrps_kinematics.multibody import MultibodyModel
from rrps_sim.figures import REPORT_EXTRA_FORCES, climb_poses
from rrps_sim.dynamics import METHODS, MultibodyDynamics, simulate
from rrps_sim.dynamics.kernels import accelerations, leg_blocks


def dense_accelerations(dyn: MultibodyDynamics, q, v, forces, M):
    """Baseline: eq. 19 as one dense (78 + 72)^2 system, solved by LAPACK."""
    F = np.zeros(78)
    Phi = np.zeros((72, 78))
    gamma = np.zeros(72)
    B = np.empty((13, 18))
    g = np.empty(13)
    W = v.reshape(13, 6)[:, 3:]
    F.reshape(13, 6)[:, :3] = dyn.mass[:, None] * dyn.geometry.gravity
    F.reshape(13, 6)[:, 3:] = -np.cross(W, np.einsum('bij,bj->bi', dyn.inertia, W))
    for k in range(6):
        leg_blocks(q, v, k, dyn.parameters.joints, B, g)
        lo, up = 6 * (1 + 2 * k), 6 * (2 + 2 * k)
        cols = np.r_[0:6, lo:lo + 12]
        Phi[12 * k:12 * k + 12, cols] = B[:12]
        gamma[12 * k:12 * k + 12] = g[:12]
        F[lo:lo + 3] -= forces[k] * B[12, 12:15]
        F[up:up + 3] += forces[k] * B[12, 12:15]
    K = np.block([[M, Phi.T], [Phi, np.zeros((72, 72))]])
    return np.linalg.solve(K, np.concatenate([F, gamma]))[:78]


def dense_rk4_run(dyn: MultibodyDynamics, forces, duration, dt) -> np.ndarray:
    """The baseline's RK4 (no stabilisation) on [q, v]; returns the final q."""
    M = np.zeros((78, 78))
    for b in range(13):
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = dyn.mass[b] * np.eye(3)
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = dyn.inertia[b]

    def f(q, v):
        P = q.reshape(13, 7)[:, 3:]
        Wb = v.reshape(13, 6)[:, 3:]
        e0, e = P[:, :1], P[:, 1:]
        pdot = 0.5 * np.concatenate([-np.sum(e * Wb, axis=1, keepdims=True),
                                     e0 * Wb + np.cross(e, Wb)], axis=1)
        dq = np.concatenate([v.reshape(13, 6)[:, :3], pdot], axis=1).ravel()
        return dq, dense_accelerations(dyn, q, v, forces, M)

    q, v = dyn.q.copy(), dyn.v.copy()
    for _ in range(int(round(duration / dt))):
        k1 = f(q, v)
        k2 = f(q + 0.5 * dt * k1[0], v + 0.5 * dt * k1[1])
        k3 = f(q + 0.5 * dt * k2[0], v + 0.5 * dt * k2[1])
        k4 = f(q + dt * k3[0], v + dt * k3[1])
        q = q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return q


def best_of(repeats, fn):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robot', default='pole_climber')
    parser.add_argument('--duration', type=float, default=0.5)
    parser.add_argument('--dt', type=float, default=0.001)
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args(argv)
    g = load_robot(args.robot)
    position, quat = g.home_position, g.home_quaternion_xyzw
    dyn = MultibodyDynamics(g)
    forces = dyn.holding_forces(position, quat) + REPORT_EXTRA_FORCES
    for method in METHODS:          # warm-up: numba compiles or loads its cache here
        simulate(g, position, quat, forces, duration=5 * args.dt, dt=args.dt, method=method)

    rows = []  # (name, value, unit, note)
    ends = {}
    ratios = {}
    for method in METHODS:
        sec, res = best_of(args.repeats, lambda: simulate(g, position, quat, forces,
                                                          duration=args.duration, dt=args.dt,
                                                          method=method))
        ratios[method] = args.duration / sec
        ends[method] = res.position[-1]
        rows.append((f'DAE {args.duration} s, {method} (simulate)', 1e3 * sec, 'ms',
                     f'{ratios[method]:.1f}x real time, {1e6 * sec / len(res.t[1:]):.0f} us/step, '
                     f'max drift {np.max(res.constraint_drift):.1e}'))

    # One evaluation of eq. 19: structured vs dense, at a moving state.
    probe = MultibodyDynamics(g, 'baumgarte')
    probe.reset(position, quat)
    for _ in range(50):
        probe.step(forces, args.dt)
    acc, lam = np.empty(78), np.empty(72)
    M = np.zeros((78, 78))
    for b in range(13):
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = probe.mass[b] * np.eye(3)
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = probe.inertia[b]
    n_eval = 2000
    sec_s, _ = best_of(args.repeats, lambda: [accelerations(probe.q, probe.v, forces, 0.0, 0.0,
                                                            probe.parameters, acc, lam)
                                              for _ in range(n_eval)])
    sec_d, acc_d = best_of(args.repeats, lambda: [dense_accelerations(probe, probe.q, probe.v,
                                                                      forces, M)
                                                  for _ in range(n_eval // 10)])
    rows.append(('eq. 19 solve, structured (numba)', 1e6 * sec_s / n_eval, 'us',
                 'Cholesky per leg + Woodbury'))
    rows.append(('eq. 19 solve, dense 150x150 (baseline)', 1e6 * sec_d / (n_eval // 10), 'us',
                 f'{(sec_d / (n_eval // 10)) / (sec_s / n_eval):.0f}x slower; max |Δacc| '
                 f'{np.max(np.abs(acc_d[-1] - acc)):.1e}'))
    base = MultibodyDynamics(g, 'baumgarte', alpha=0.0, beta=0.0)
    base.reset(position, quat)
    sec_b, q_b = best_of(1, lambda: dense_rk4_run(base, forces, args.duration, args.dt))
    plain = simulate(g, position, quat, forces, duration=args.duration, dt=args.dt,
                     method='baumgarte', alpha=0.0, beta=0.0)
    diff = np.max(np.abs(base.model.pose_from_coordinates(q_b)[0] - plain.position[-1]))
    rows.append((f'DAE {args.duration} s, dense eq. 19 RK4 (baseline)', 1e3 * sec_b, 'ms',
                 f'{args.duration / sec_b:.2f}x real time; end differs by {diff:.1e} m'))

    # Multibody DK along the climb.
    model = MultibodyModel(g)
    P, Q, _, _ = climb_poses()
    L = inverse_kinematics(g, P, Q).lengths
    seeds = [model.coordinates_from_pose(P[k], Q[k]) for k in range(len(P))]
    model.direct_kinematics(L[1], seeds[0])
    dk = {}
    for solver in ('structured', 'sparse', 'dense'):
        times, its, errs = [], [], []
        for k in range(1, len(P)):
            sec, res = best_of(args.repeats, lambda: model.direct_kinematics(L[k], seeds[k - 1],
                                                                             solver=solver))
            times.append(sec)
            its.append(res.iterations)
            errs.append(np.max(np.abs(res.position - P[k])))
        dk[solver] = np.array(times)
        rows.append((f'multibody DK (91 coords), {solver}', 1e3 * np.median(times), 'ms median',
                     f'max {1e3 * np.max(times):.2f} ms, {np.mean(its):.1f} iterations, '
                     f'{res.flops / 1e3:.0f} kflop, '
                     f'max pose error {np.max(errs):.1e} m'))
    fk_times = [best_of(args.repeats, lambda: forward_kinematics(g, L[k], P[k - 1], Q[k - 1]))[0]
                for k in range(1, len(P))]
    rows.append(('pose-level FK (6 DOF), for scale', 1e3 * np.median(fk_times), 'ms median', ''))

    print(f'# rrps dynamics benchmark: {g.name}, {platform.processor() or platform.machine()}, '
          f'{os.cpu_count()} cores, Python {sys.version.split()[0]}')
    width = max(len(r[0]) for r in rows)
    for name, value, unit, note in rows:
        print(f'{name:{width}s}  {value:10.3f} {unit:10s}  {note}')
    ok_rt = ratios['hybrid'] >= 5.0
    ok_dk = np.max(dk['structured']) <= 2e-3
    agree = max(np.max(np.abs(ends[m] - ends['hybrid'])) for m in METHODS)
    print(f'\nreal-time ratio (hybrid, the paper\'s integrator): {ratios["hybrid"]:.1f}x '
          f'(target >= 5x): {"PASS" if ok_rt else "FAIL"}')
    print(f'multibody DK worst solve: {1e3 * np.max(dk["structured"]):.2f} ms (target <= 2 ms): '
          f'{"PASS" if ok_dk else "FAIL"}')
    print(f'the three integrators end within {agree:.1e} m of each other')
    return 0 if ok_rt and ok_dk else 1


if __name__ == '__main__':
    sys.exit(main())
