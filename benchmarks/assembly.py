#!/usr/bin/env python3
"""Benchmark of all assembly modes: the continuation against the multi-start search, same run.

    python benchmarks/assembly.py [--repeats 20] [--baseline-repeats 3]

Cases: Dietmaier's platform (40 real solutions; data as in tests/unit/kinematics/test_assembly.py,
P. Dietmaier 1998, six-digit values from the CuikSuite documentation) and every shipped robot at
its home lengths and at lengths changed by a few percent. For each: the continuation
(``assembly_modes(method='continuation')``, median wall and CPU time over ``--repeats`` calls),
the baseline multi-start search (``method='multistart'``, 20000 seeds, median over
``--baseline-repeats``), whether both found the same set of modes (to 1e-9), and the paths'
record. Target (this 2-core machine): every real mode in <= 50 ms (wall, median),
certified (all 40 paths tracked).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import numpy as np

from rrps_description.geometry import RobotGeometry, load_robot, shipped_robots
from rrps_kinematics import assembly_modes
from rrps_kinematics.backend import numba_enabled
from rrps_kinematics.homotopy_run import real_endpoints

DIETMAIER_A = np.array([[0.0, 0.0, 0.0], [1.107915, 0.0, 0.0], [0.549094, 0.756063, 0.0],
                        [0.735077, -0.223935, 0.525991], [0.514188, -0.526063, -0.368418],
                        [0.590473, 0.094733, -0.205018]])
DIETMAIER_B = np.array([[0.0, 0.0, 0.0], [0.542805, 0.0, 0.0], [0.956919, -0.528915, 0.0],
                        [0.665885, -0.353482, 1.402538], [0.478359, 1.158742, 0.107672],
                        [-0.137087, -0.235121, 0.353913]])
DIETMAIER_L = np.array([1.0, 0.645275, 1.086284, 1.503439, 1.281933, 0.771071])
TARGET_MS = 50.0
CHANGE = np.array([1.03, 0.98, 1.01, 1.0, 0.97, 1.02])


def cases():
    yield 'dietmaier (published lengths)', RobotGeometry(ring_a_anchors=DIETMAIER_A, ring_b_anchors=DIETMAIER_B,
                                                         name='dietmaier'), DIETMAIER_L
    for name in shipped_robots():
        g = load_robot(name)
        yield f'{name} (home)', g, g.home_lengths
        yield f'{name} (lengths changed)', g, g.home_lengths * CHANGE


def timed(fn, repeats):
    """(result, median wall [s], median CPU [s]) over ``repeats`` calls."""
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        result = fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return result, float(np.median(wall)), float(np.median(cpu))


def same_set(a, b, atol=1e-9) -> bool:
    if len(a) != len(b):
        return False
    for p, q in zip(a.positions, a.quaternions_xyzw):
        k = np.argmin(np.linalg.norm(b.positions - p, axis=1) + np.linalg.norm(b.quaternions_xyzw - q, axis=1))
        if np.max(np.abs(b.positions[k] - p)) > atol or np.max(np.abs(b.quaternions_xyzw[k] - q)) > atol:
            return False
    return True


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--repeats', type=int, default=20, help='continuation calls per case')
    parser.add_argument('--baseline-repeats', type=int, default=3, help='multi-start calls per case')
    args = parser.parse_args(argv)
    if not numba_enabled():
        print('the continuation needs numba (RRPS_NUMBA=0 or numba missing): nothing to measure')
        return 1
    print(f'rrps assembly-modes benchmark: Python {platform.python_version()}, {os.cpu_count()} CPUs, '
          f'load average {os.getloadavg()[0]:.1f}, {args.repeats} continuation / {args.baseline_repeats} '
          'multi-start calls per case')
    header = (f'{"case":34s} {"modes":>5s} {"cert.":>5s} {"div.":>4s} {"steps":>5s} {"cont. ms":>9s} '
              f'{"CPU ms":>7s} {"tries":>5s} {"multi ms":>9s} {"speed-up":>8s} {"same set":>8s}  '
              f'target <= {TARGET_MS:.0f} ms')
    print(header)
    print('-' * len(header))
    results = []
    for name, g, L in cases():
        assembly_modes(g, L)                       # numba compiles or loads its cache here
        cont, wall, cpu = timed(lambda: assembly_modes(g, L), args.repeats)
        multi, wall_m, _ = timed(lambda: assembly_modes(g, L, method='multistart'), args.baseline_repeats)
        ends = real_endpoints(g, L)
        same = same_set(cont, multi)
        met = wall * 1e3 <= TARGET_MS and cont.certified and same
        results.append(met)
        print(f'{name:34s} {len(cont):5d} {"yes" if cont.certified else "NO":>5s} {ends.diverged:4d} '
              f'{int(ends.steps.sum()):5d} {wall * 1e3:9.1f} {cpu * 1e3:7.1f} {ends.attempts:5d} {wall_m * 1e3:9.1f} '
              f'{wall_m / wall:7.1f}x {"yes" if same else "NO":>8s}  {"MET" if met else "MISSED"}')
    print('-' * len(header))
    print('cert.: all 40 paths tracked (none failed); div.: paths that went to e.e = 0 (no pose); steps: '
          'predictor-corrector steps of the 40 paths; tries: gammas tried; multi: the multi-start baseline '
          '(20000 seeds).')
    print(f'target every mode in <= {TARGET_MS:.0f} ms, certified, same set as the multi-start: '
          f'{"MET" if all(results) else "MISSED"} ({sum(results)} of {len(results)} cases)')
    return 0 if all(results) else 1


if __name__ == '__main__':
    sys.exit(main())
