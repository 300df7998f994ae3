#!/usr/bin/env python3
"""Benchmark of the kinematics core: IK and warm-started FK, against baselines in the same run.

    python benchmarks/kinematics.py [--robot pole_climber] [--samples 2000] [--batch 200000]

A smooth trajectory of ring_b (1 mm and 0.01 rad between successive poses, i.e. a fast motion
sampled at a few hundred Hz) is solved by inverse kinematics; forward kinematics then recovers
each pose from its lengths, seeded by the previous pose (the real-time use of fk_node).
Baselines: ``scipy.optimize.fsolve`` on the six leg equations (unknowns: position and a rotation
vector relative to the seed), a plain NumPy Newton loop (np.linalg.solve per iteration) and the
serial batch kernels (what the parallel ones are checked against, bit for bit, in the same run).
Single-solve times are medians over ``--samples`` calls; batches report throughput (best of 3).
Targets (this 2-core machine; a C Newton FK takes about 1 us): FK warm single <= 5 us median
and >= 100x faster than fsolve; the NumPy fallback's single solve no slower than the plain NumPy
Newton loop; batch FK >= 2 M solves/s (both cores); batch IK >= 2 M poses/s.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
import sys
import time

import numpy as np
from scipy.optimize import fsolve

import rrps_kinematics.forward
import rrps_kinematics.inverse
from rrps_description.geometry import load_robot
from rrps_description.rotations import (
    quat_multiply_xyzw,
    quat_xyzw_to_matrix,
    rotation_angle_between,
    rotation_vector_to_matrix,
    rotation_vector_to_quat_xyzw,
)
from rrps_kinematics import (
    ForwardSolver,
    InverseKinematicsResult,
    compiled_backend_available,
    forward_kinematics,
    inverse_jacobian,
    inverse_kinematics,
    leg_lengths,
)


def trajectory(g, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """n poses, each 1 mm and 0.01 rad from the previous one, kept near home (a bounded walk)."""
    rng = np.random.default_rng(seed)
    P = np.empty((n, 3))
    Q = np.empty((n, 4))
    p = g.home_position.copy()
    q = g.home_quaternion_xyzw.copy()
    for k in range(n):
        step = rng.normal(size=3)
        step = 1e-3 * step / np.linalg.norm(step) - 0.02 * (p - g.home_position)
        p = p + step
        rv = rng.normal(size=3)
        rv = 0.01 * rv / np.linalg.norm(rv)
        q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(rv), q)
        # Pull the orientation back towards home so the walk stays in the workspace.
        q = q + 0.02 * (g.home_quaternion_xyzw - q)
        q /= np.linalg.norm(q)
        P[k], Q[k] = p, q
    return P, Q


def median_us(fn, args_list) -> float:
    times = np.empty(len(args_list))
    for k, args in enumerate(args_list):
        t0 = time.perf_counter()
        fn(*args)
        times[k] = time.perf_counter() - t0
    return float(np.median(times) * 1e6)


def throughput(fn, n: int, repeats: int = 3) -> float:
    return cores_and_throughput(fn, n, repeats)[1]


def cores_and_throughput(fn, n: int, repeats: int = 3) -> tuple[float, float]:
    """Best of ``repeats``: (cores the process used during it = CPU time / wall time, n / s).
    On a shared machine the cores tell whether a parallel kernel had both."""
    best, cores = np.inf, 0.0
    for _ in range(repeats):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        wall = time.perf_counter() - t0
        if wall < best:
            best, cores = wall, (time.process_time() - c0) / wall
    return cores, n / best


@contextlib.contextmanager
def serial_batches():
    """Baseline: every batch through the serial kernels (the parallel ones' reference)."""
    saved = rrps_kinematics.forward.PARALLEL_BATCH, rrps_kinematics.inverse.PARALLEL_BATCH
    rrps_kinematics.forward.PARALLEL_BATCH = rrps_kinematics.inverse.PARALLEL_BATCH = 10 ** 18
    try:
        yield
    finally:
        rrps_kinematics.forward.PARALLEL_BATCH, rrps_kinematics.inverse.PARALLEL_BATCH = saved


def fsolve_fk(g, L, seed_p, seed_q):
    """Baseline: scipy.optimize.fsolve on l_i(p, exp(v) R_seed) - L_i = 0."""
    R0 = quat_xyzw_to_matrix(seed_q)
    A, B = g.ring_a_anchors, g.ring_b_anchors

    def legs(x):
        R = rotation_vector_to_matrix(x[3:]) @ R0
        return np.linalg.norm(x[:3] + B @ R.T - A, axis=1) - L

    x = fsolve(legs, np.concatenate([seed_p, np.zeros(3)]), xtol=1e-13)
    return x[:3], rotation_vector_to_matrix(x[3:]) @ R0


def numpy_newton_fk(g, L, seed_p, seed_q, tol=1e-12, max_iterations=30):
    """Baseline: a plain Newton loop with NumPy calls (IK, inverse Jacobian, np.linalg.solve)."""
    p = np.array(seed_p, dtype=float)
    R = quat_xyzw_to_matrix(seed_q)
    for _ in range(max_iterations):
        ik = InverseKinematicsResult(g, p, R)
        err = L - ik.lengths
        if np.max(np.abs(err)) <= tol:
            break
        dx = np.linalg.solve(inverse_jacobian(ik), err)
        p = p + dx[:3]
        R = rotation_vector_to_matrix(dx[3:]) @ R
    return p, R


def pose_error(P, R, P_ref, Q_ref) -> float:
    return float(np.max(np.linalg.norm(P - P_ref, axis=-1))
                 + np.max(rotation_angle_between(R, quat_xyzw_to_matrix(Q_ref))))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robot', default='pole_climber')
    parser.add_argument('--samples', type=int, default=2000, help='single solves to time')
    parser.add_argument('--batch', type=int, default=200_000, help='poses per batch')
    args = parser.parse_args(argv)
    g = load_robot(args.robot)
    numba_ok = compiled_backend_available()
    n = args.samples
    P, Q = trajectory(g, n + 1)
    L = inverse_kinematics(g, P, Q).lengths
    PB, QB = trajectory(g, args.batch + 1, seed=1)
    LB = inverse_kinematics(g, PB, QB).lengths

    # Warm up (numba compiles or loads its cache here, outside every timing).
    forward_kinematics(g, L[1], P[0], Q[0])
    forward_kinematics(g, LB[1:], PB[:-1], QB[:-1])
    leg_lengths(g, PB, QB)
    with serial_batches():
        forward_kinematics(g, L[1:3], P[0:2], Q[0:2])
        leg_lengths(g, P[:2], Q[:2])

    rows = []  # (name, value, unit, note)
    singles = [(g, P[k], Q[k]) for k in range(n)]
    ik_single = median_us(lambda g_, p, q: inverse_kinematics(g_, p, q).lengths, singles)
    rows.append(('IK single (inverse_kinematics, NumPy)', ik_single, 'us median', ''))
    ik_fast_single = median_us(lambda g_, p, q: leg_lengths(g_, p, q), singles)
    rows.append(('IK single (leg_lengths, auto backend)', ik_fast_single, 'us median', ''))
    ik_batch_numpy = throughput(lambda: inverse_kinematics(g, PB, QB).lengths, args.batch)
    rows.append(('IK batch (inverse_kinematics, NumPy)', ik_batch_numpy / 1e6, 'M poses/s', ''))
    ik_cores, ik_batch = cores_and_throughput(lambda: leg_lengths(g, PB, QB), args.batch)
    with serial_batches():
        ik_batch_serial = throughput(lambda: leg_lengths(g, PB, QB), args.batch)
    ik_same = np.array_equal(leg_lengths(g, PB, QB), _serial(leg_lengths, g, PB, QB))
    rows.append(('IK batch (leg_lengths, auto: both cores)', ik_batch / 1e6, 'M poses/s',
                 f'{ik_cores:.2f} cores used; bit for bit the serial kernel: {"yes" if ik_same else "NO"}'))
    rows.append(('baseline: IK batch, serial kernel', ik_batch_serial / 1e6, 'M poses/s', ''))

    warm = [(g, L[k + 1], P[k], Q[k]) for k in range(n)]
    fk_single = median_us(lambda g_, lengths, p, q: forward_kinematics(g_, lengths, p, q), warm)
    res = [forward_kinematics(g, L[k + 1], P[k], Q[k]) for k in range(n)]
    fk_err = pose_error(np.array([r.position for r in res]), np.array([r.rotation for r in res]),
                        P[1:], Q[1:])
    its = np.array([r.iterations for r in res])
    rows.append(('FK warm single (forward_kinematics, auto)', fk_single, 'us median',
                 f'{np.mean(its):.2f} iterations, max pose error {fk_err:.1e}'))
    solver = ForwardSolver(g)
    fk_stream = median_us(lambda g_, lengths, p, q: solver(lengths, p, q), warm)
    rows.append(('FK warm single (ForwardSolver, a stream)', fk_stream, 'us median', ''))
    fk_single_np = median_us(lambda g_, lengths, p, q: forward_kinematics(g_, lengths, p, q, backend='numpy'),
                             warm[: max(n // 4, 10)])
    rows.append(('FK warm single (forward_kinematics, NumPy)', fk_single_np, 'us median',
                 'the RRPS_NUMBA=0 fallback'))
    fk_newton = median_us(lambda g_, lengths, p, q: numpy_newton_fk(g_, lengths, p, q), warm)
    out = [numpy_newton_fk(g, L[k + 1], P[k], Q[k]) for k in range(n)]
    err_newton = pose_error(np.array([o[0] for o in out]), np.array([o[1] for o in out]), P[1:], Q[1:])
    rows.append(('baseline: plain NumPy Newton loop', fk_newton, 'us median',
                 f'max pose error {err_newton:.1e}'))
    fk_fsolve = median_us(lambda g_, lengths, p, q: fsolve_fk(g_, lengths, p, q), warm)
    out = [fsolve_fk(g, L[k + 1], P[k], Q[k]) for k in range(n)]
    err_fsolve = pose_error(np.array([o[0] for o in out]), np.array([o[1] for o in out]), P[1:], Q[1:])
    rows.append(('baseline: scipy.optimize.fsolve', fk_fsolve, 'us median',
                 f'max pose error {err_fsolve:.1e}'))

    fk_cores, fk_batch = cores_and_throughput(lambda: forward_kinematics(g, LB[1:], PB[:-1], QB[:-1]),
                                              args.batch)
    fb = forward_kinematics(g, LB[1:], PB[:-1], QB[:-1])
    fs = _serial(forward_kinematics, g, LB[1:], PB[:-1], QB[:-1])
    fk_same = all(np.array_equal(a, b) for a, b in zip(fb, fs))
    with serial_batches():
        fk_batch_serial = throughput(lambda: forward_kinematics(g, LB[1:], PB[:-1], QB[:-1]), args.batch)
    rows.append(('FK warm batch (forward_kinematics, auto)', fk_batch / 1e3, 'k solves/s',
                 f'{fk_cores:.2f} cores used; {np.mean(fb.converged) * 100:.1f} % converged; bit for '
                 f'bit the serial kernel: {"yes" if fk_same else "NO"}'))
    rows.append(('baseline: FK batch, serial kernel', fk_batch_serial / 1e3, 'k solves/s', ''))
    nb = min(args.batch, 20_000)
    fk_batch_np = throughput(lambda: forward_kinematics(g, LB[1:nb + 1], PB[:nb], QB[:nb], backend='numpy'),
                             nb, repeats=2)
    rows.append(('FK warm batch (forward_kinematics, NumPy)', fk_batch_np / 1e3, 'k solves/s', ''))

    print(f'rrps kinematics benchmark: robot {g.name}, numba backend '
          f'{"on" if numba_ok else "OFF"}, Python {platform.python_version()}, '
          f'{os.cpu_count()} CPUs, {n} single solves, batches of {args.batch}, '
          f'load average {os.getloadavg()[0]:.1f}')
    print(f'{"what":46s} {"value":>12s}  {"unit":11s} note')
    print('-' * 100)
    for name, value, unit, note in rows:
        print(f'{name:46s} {value:12.3f}  {unit:11s} {note}')
    print('-' * 100)
    print(f'FK warm single vs fsolve: {fk_fsolve / fk_single:.1f}x faster; '
          f'vs plain NumPy Newton: {fk_newton / fk_single:.1f}x faster; NumPy fallback vs the plain '
          f'loop: {fk_newton / fk_single_np:.1f}x faster; batch FK on both cores vs the serial kernel: '
          f'{fk_batch / fk_batch_serial:.2f}x')
    targets = [
        ('FK warm single <= 5 us median', fk_single <= 5.0, f'{fk_single:.1f} us'),
        ('FK warm single >= 100x faster than fsolve', fk_fsolve / fk_single >= 100.0,
         f'{fk_fsolve / fk_single:.1f}x'),
        ('NumPy fallback single <= plain NumPy loop', fk_single_np <= fk_newton,
         f'{fk_single_np:.0f} us vs {fk_newton:.0f} us'),
        ('batch FK >= 2 M solves/s', fk_batch >= 2e6, f'{fk_batch / 1e6:.2f} M/s'),
        ('batch IK >= 2 M poses/s', ik_batch >= 2e6, f'{ik_batch / 1e6:.2f} M/s'),
        ('parallel batches = serial kernels bit for bit', fk_same and ik_same, ''),
    ]
    for name, met, value in targets:
        print(f'target {name:46s} {"MET" if met else "MISSED":7s} ({value})')
    return 0 if all(met for _, met, _ in targets) else 1


def _serial(function, *args):
    with serial_batches():
        return function(*args)


if __name__ == '__main__':
    sys.exit(main())
