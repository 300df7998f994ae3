#!/usr/bin/env python3
"""Benchmark of the load-feasible workspace at the viewer's resolution, against the plain
reachable workspace in the same run.

    python benchmarks/load_workspace.py [--resolution 0.02] [--repeats 5] [--payloads 0,20,40]

For each climbing robot shipped (pole, facade, frame climber) at its home orientation, ring_a
gripping a wall (its axis horizontal), rows:

* ``plain``: :func:`rrps_kinematics.workspace.reachable_workspace` (what the viewer drew before);
* ``load-feasible``: :func:`rrps_loads.load_workspace.load_workspace` from scratch (the plain
  workspace plus the statics of every reachable point, compiled kernel), per payload on ring_b;
* ``payload change``: the same with the plain workspace given (what the viewer's payload slider
  costs: the orientation did not change);
* for the loads: the statics kernel interpreted over the same reachable points (``backend='numpy'``,
  what ``RRPS_NUMBA=0`` runs).

Times are the median of ``--repeats`` runs. Target: the load-feasible workspace within 0.5 s
(the viewer's budget for the plain one): MET/MISSED per robot on its slowest payload.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import compiled_backend_available
from rrps_kinematics.workspace import reachable_workspace
from rrps_loads.load_workspace import load_workspace

ROBOTS = ('pole_climber', 'facade_climber', 'frame_climber')
WALL = rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0]))
TARGET = 0.5


def median_time(fn, repeats: int) -> tuple[object, float]:
    times, value = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        value = fn()
        times.append(time.perf_counter() - t0)
    return value, statistics.median(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--resolution', type=float, default=0.02, help="grid spacing [m] (the viewer's)")
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--payloads', default='0,20,40', help='payloads on ring_b [kg], comma-separated')
    args = parser.parse_args(argv)
    payloads = [float(v) for v in args.payloads.split(',')]
    h = args.resolution
    print(f'rrps load-feasible workspace benchmark: numba backend {"on" if compiled_backend_available() else "OFF"}, '
          f'Python {platform.python_version()}, {os.cpu_count()} CPUs, load average '
          f'{os.getloadavg()[0]:.1f}, grid {h * 1e3:.0f} mm, home orientation, ring_a on a wall, '
          f'median of {args.repeats}')
    header = (f'{"robot":15s} {"payload":>8s} {"volume [L]":>11s} {"of plain":>9s} {"plain [s]":>10s} '
              f'{"load-feasible [s]":>18s} {"payload change [s]":>19s} {"interpreted [s]":>16s} {"verdict":>8s}')
    print(header)
    print('-' * len(header))
    verdicts = []
    for name in ROBOTS:
        g = load_robot(name)
        q = g.home_quaternion_xyzw
        load_workspace(g, q, resolution=h * 4, world_q_support=WALL)        # warm-up: numba loads or compiles
        plain, t_plain = median_time(lambda: reachable_workspace(g, q, resolution=h), args.repeats)
        worst = 0.0
        for mass in payloads:
            payload = Payload(ring='ring_b', mass=mass) if mass > 0.0 else None
            ws, t_load = median_time(lambda: load_workspace(g, q, resolution=h, world_q_support=WALL,
                                                            payload=payload), args.repeats)
            _, t_change = median_time(lambda: load_workspace(g, plain=plain, world_q_support=WALL,
                                                             payload=payload), args.repeats)
            ref, t_numpy = median_time(lambda: load_workspace(g, plain=plain, world_q_support=WALL, payload=payload,
                                                              backend='numpy'), 1)
            assert np.array_equal(ref.labels, ws.labels), f'{name} {mass} kg: the interpreted kernel differs'
            worst = max(worst, t_load)
            print(f'{name:15s} {mass:8g} {ws.volume * 1e3:11.2f} {ws.volume / plain.volume:9.1%} {t_plain:10.3f} '
                  f'{t_load:18.3f} {t_change:19.3f} {t_numpy:16.3f}')
        verdict = 'MET' if worst <= TARGET else 'MISSED'
        verdicts.append(verdict)
        print(f'{name:15s} {"":8s} {"":11s} {"":9s} {"":10s} {"slowest " + f"{worst:.3f}":>18s} {"":19s} {"":16s} '
              f'{verdict:>8s}')
    print('-' * len(header))
    print(f'target: load-feasible workspace at the viewer resolution <= {TARGET} s: '
          f'{"MET" if all(v == "MET" for v in verdicts) else "MISSED"} ({", ".join(verdicts)})')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
