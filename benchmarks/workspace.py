#!/usr/bin/env python3
"""Benchmark of the reachable workspace: a 100^3 grid with every limit, against baselines in the same run.

    python benchmarks/workspace.py [--robot pole_climber] [--points-per-axis 100] [--loop-sample 2000]

The grid is a cube of ``--points-per-axis``^3 ring_b positions around the robot's automatic
bounds, at its home orientation; every point is checked against every limit (stroke, joint
cones, interference, conditioning). Rows:

* ``reachable_workspace`` with the numba kernel on every thread (auto backend), with the serial
  kernel (baseline: the parallel one must classify every point alike), and with the same kernel
  interpreted (``backend='numpy'``, what ``RRPS_NUMBA=0`` runs), each over the whole grid;
* baseline: a plain Python loop over the points calling
  ``limits.margins(inverse_kinematics(...))`` per point, timed on ``--loop-sample`` random grid
  points and EXTRAPOLATED to the whole grid (labelled as such).

Target (this 2-core machine): the 1,000,000-point grid (the default) with every limit
in <= 0.5 s (both cores).

Then the volumes of the shipped robots at their home orientation (constant-orientation
workspace) at two resolutions (stroke / 25 and stroke / 50), and over an orientation range of
±0.1 rad in roll, pitch and yaw (total-orientation workspace, 27 orientations, stroke / 25).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
import sys
import time

import numpy as np

import rrps_kinematics.workspace
from rrps_description.geometry import load_robot, shipped_robots
from rrps_kinematics import compiled_backend_available, inverse_kinematics, margins
from rrps_kinematics.workspace import (
    NEAR_SINGULAR,
    REACHABLE,
    SINGULAR_THRESHOLD,
    UNREACHABLE,
    automatic_bounds,
    orientation_range,
    reachable_workspace,
)


def cube_grid(g, n: int) -> tuple[np.ndarray, float]:
    """Bounds of a cube holding the automatic bounds, and the spacing giving n points per axis."""
    box = automatic_bounds(g, g.home_quaternion_xyzw).reshape(3, 2)
    centre = box.mean(axis=1)
    side = float(np.max(box[:, 1] - box[:, 0])) * 1.02
    bounds = np.column_stack([centre - side / 2, centre + side / 2]).ravel()
    return bounds, side / (n - 1)


def loop_labels(g, points: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Baseline: one margins(inverse_kinematics(...)) call per point, in a Python loop."""
    out = np.empty(len(points), dtype=np.int8)
    for k, p in enumerate(points):
        m = margins(g, inverse_kinematics(g, p, q))
        out[k] = (UNREACHABLE if not m.ok
                  else NEAR_SINGULAR if m.inverse_condition < SINGULAR_THRESHOLD else REACHABLE)
    return out


#: Seconds for the 1,000,000-point grid with every limit (the target).
GRID_TARGET = 0.5


@contextlib.contextmanager
def serial_kernel():
    """Baseline: the grid through the serial kernel (the parallel one's reference)."""
    saved = rrps_kinematics.workspace.PARALLEL_BATCH
    rrps_kinematics.workspace.PARALLEL_BATCH = 10 ** 18
    try:
        yield
    finally:
        rrps_kinematics.workspace.PARALLEL_BATCH = saved


def timed(fn):
    c0, t0 = time.process_time(), time.perf_counter()
    value = fn()
    wall = time.perf_counter() - t0
    timed.cores = (time.process_time() - c0) / wall   # cores the process used (CPU / wall time)
    return value, wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robot', default='pole_climber')
    parser.add_argument('--points-per-axis', type=int, default=100)
    parser.add_argument('--loop-sample', type=int, default=2000,
                        help='grid points timed in the per-point loop (then extrapolated)')
    args = parser.parse_args(argv)
    g = load_robot(args.robot)
    q = g.home_quaternion_xyzw
    n = args.points_per_axis
    bounds, h = cube_grid(g, n)
    total = n ** 3

    # Warm up (numba compiles or loads its cache here, outside every timing).
    reachable_workspace(g, q, resolution=h * 10, bounds=bounds)
    with serial_kernel():
        reachable_workspace(g, q, resolution=h * 10, bounds=bounds)

    ours, t_ours, cores = min(((*timed(lambda: reachable_workspace(g, q, resolution=h, bounds=bounds)),
                                timed.cores) for _ in range(3)), key=lambda r: r[1])
    assert ours.labels.size == total, ours.shape
    with serial_kernel():
        serial, t_serial = min((timed(lambda: reachable_workspace(g, q, resolution=h, bounds=bounds))
                                for _ in range(2)), key=lambda r: r[1])
    agree_serial = bool(np.array_equal(ours.labels, serial.labels))
    ref, t_numpy = timed(lambda: reachable_workspace(g, q, resolution=h, bounds=bounds, backend='numpy'))
    rng = np.random.default_rng(0)
    flat = rng.choice(total, size=min(args.loop_sample, total), replace=False)
    index = np.stack(np.unravel_index(flat, ours.shape), axis=-1)
    sample = ours.origin + h * index
    loop, t_loop_sample = timed(lambda: loop_labels(g, sample, q))
    t_loop = t_loop_sample / len(sample) * total
    agree_numpy = bool(np.array_equal(ours.labels, ref.labels))
    agree_loop = int(np.sum(loop != ours.labels.ravel()[flat]))

    print(f'rrps workspace benchmark: robot {g.name}, numba backend '
          f'{"on" if compiled_backend_available() else "OFF"}, Python {platform.python_version()}, '
          f'{os.cpu_count()} CPUs, grid {n}^3 = {total:,} points, spacing {h * 1e3:.2f} mm, '
          f'every limit, home orientation, load average {os.getloadavg()[0]:.1f}')
    rows = [('reachable_workspace, numba kernel on every thread (auto)', t_ours),
            ('baseline: the same, serial numba kernel', t_serial),
            ('reachable_workspace, the kernel interpreted (RRPS_NUMBA=0)', t_numpy),
            (f'baseline: margins() per point in a loop, EXTRAPOLATED from {len(sample):,}', t_loop)]
    width = max(len(name) for name, _ in rows)
    print(f'{"what":{width}s} {"time [s]":>10s} {"points/s":>12s} {"speed-up":>9s}')
    print('-' * (width + 34))
    for name, t in rows:
        print(f'{name:{width}s} {t:10.2f} {total / t:12,.0f} {t_loop / t:8.1f}x')
    print('-' * (width + 34))
    print(f'speed-up of the numba kernel over the per-point loop: {t_loop / t_ours:.1f}x; over the '
          f'kernel interpreted: {t_numpy / t_ours:.1f}x')
    print(f'same classification: parallel vs serial kernel on all {total:,} points: '
          f'{"yes" if agree_serial else "NO"}; compiled vs interpreted: '
          f'{"yes" if agree_numpy else "NO"}; loop vs numba on the {len(sample):,} sampled points: '
          f'{"yes" if agree_loop == 0 else f"NO ({agree_loop} differ)"}')
    print(f'{g.name}: reachable {ours.volume:.6f} m^3, near-singular {ours.near_singular_volume:.6f} m^3 '
          f'(1/cond < {SINGULAR_THRESHOLD}), excluded by {ours.excluded_by}')
    grid_met = t_ours <= GRID_TARGET * total / 1e6
    print(f'target {total:,} points with every limit <= {GRID_TARGET * total / 1e6:.2f} s: '
          f'{"MET" if grid_met else "MISSED"} ({t_ours:.2f} s; {t_serial / t_ours:.2f}x the serial kernel, '
          f'{cores:.2f} cores used)')

    print()
    print('Reachable volumes of the shipped robots at their home orientation [m^3] '
          '(near-singular part in brackets)')
    print(f'{"robot":16s} {"stroke/25":>24s} {"stroke/50":>24s} {"change":>7s} '
          f'{"±0.1 rad r/p/y, stroke/25":>27s} {"time [s]":>9s}')
    print('-' * 112)
    for name in shipped_robots():
        r = load_robot(name)
        stroke = r.max_length - r.min_length
        t0 = time.perf_counter()
        coarse = reachable_workspace(r, resolution=stroke / 25)
        fine = reachable_workspace(r, resolution=stroke / 50)
        ranged = reachable_workspace(r, orientation_range(r.home_quaternion_xyzw, roll=(-0.1, 0.1),
                                                          pitch=(-0.1, 0.1), yaw=(-0.1, 0.1), step=0.1),
                                     resolution=stroke / 25)
        elapsed = time.perf_counter() - t0

        def cell(ws):
            return f'{ws.volume:.4e} ({ws.near_singular_volume:.1e})'

        print(f'{name:16s} {cell(coarse):>24s} {cell(fine):>24s} '
              f'{(fine.volume - coarse.volume) / fine.volume * 100:+6.2f}% {cell(ranged):>27s} '
              f'{elapsed:9.2f}')
        print(f'{"":16s} {f"h = {stroke / 25 * 1e3:.2f} mm":>24s} {f"h = {stroke / 50 * 1e3:.2f} mm":>24s}')
    viewer_ok = viewer_recompute_table()
    return 0 if agree_numpy and agree_serial and agree_loop == 0 and grid_met and viewer_ok else 1


#: The viewer redraws the workspace within this time of an orientation change (issue target).
VIEWER_RECOMPUTE_TARGET = 0.5


def viewer_recompute_table() -> bool:
    """The viewer's recomputation (WorkspaceView at its default 20 mm) after a turn of ring_b, per
    shipped robot, against the 0.5 s target; baseline: the same computation at 10 mm."""
    from rrps_description.geometry import shipped_robots
    from rrps_description.rotations import rotation_vector_to_quat_xyzw
    from rrps_viewer._workspace import WorkspaceView

    print()
    print(f'Viewer: workspace recomputed after ring_b turns 0.1 rad (WorkspaceView, default resolution; '
          f'target <= {VIEWER_RECOMPUTE_TARGET} s)')
    print(f'{"robot":16s} {"20 mm [s]":>10s} {"baseline 10 mm [s]":>19s} {"boundary points (20 mm)":>24s}  verdict')
    ok = True
    reachable_workspace(load_robot('master_robot'), [0, 0, 0, 1], resolution=0.005)  # compiled once
    for name in shipped_robots():
        g = load_robot(name)
        seconds, points = {}, {}
        for resolution in (0.02, 0.01):
            view = WorkspaceView(g, resolution=resolution)
            view.request(rotation_vector_to_quat_xyzw(np.array([0.1, 0.0, 0.0])))
            while view.latest() is None:
                time.sleep(0.005)
            seconds[resolution] = view.latest().seconds
            points[resolution] = len(view.latest().boundary)
        met = seconds[0.02] <= VIEWER_RECOMPUTE_TARGET
        ok &= met
        print(f'{name:16s} {seconds[0.02]:10.3f} {seconds[0.01]:19.3f} {points[0.02]:24d}  '
              f'{"MET" if met else "MISSED"}')
    return ok


if __name__ == '__main__':
    sys.exit(main())
