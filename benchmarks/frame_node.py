#!/usr/bin/env python3
"""Benchmark of the frame-node search: planning time per junction against the plain grid search.

    python benchmarks/frame_node.py [--robot frame_climber] [--repeat 1]

For each junction (30, 45, 60, 90 deg, in the column's web plane and out of it) the crossing is
searched twice in the same run:

* ``batched``: ``FrameNodePlanner`` as shipped, every candidate of a phase checked in one batch
  per support attitude (kinematics, beam clearance and statics);
* baseline ``plain grid``: the same candidates checked one at a time (``batched=False``).

Both must choose the same crossing (checked). Target: each junction planned in under 10 s
(MET / MISSED on the batched time). Then the 90 deg node without the extra ring DOF: the refusal
and its time.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_description.geometry import load_robot

TARGET = 10.0  # s per junction
JUNCTIONS = [(deg, out) for deg in (30, 45, 60, 90) for out in (False, True)]


def timed(make, repeat: int):
    best, planner = float('inf'), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        planner = make()
        best = min(best, time.perf_counter() - t0)
    return best, planner


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('--robot', default='frame_climber')
    p.add_argument('--repeat', type=int, default=1, help='best of N runs per row')
    args = p.parse_args()
    g = load_robot(args.robot)
    print(f'# frame-node search, {g.name}, {platform.processor() or platform.machine()}, '
          f'{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}')
    print('| junction | candidates | batched [s] | plain grid [s] | speed-up | same plan | score | verdict |')
    print('|---|---|---|---|---|---|---|---|')
    worst = 0.0
    for deg, out in JUNCTIONS:
        t_fast, fast = timed(lambda: FrameNodePlanner(g, deg, out), args.repeat)
        t_plain, plain = timed(lambda: FrameNodePlanner(g, deg, out, batched=False), args.repeat)
        label = f'{deg} deg {"out of" if out else "in"} plane'
        if fast.crossing is None:
            print(f'| {label} | - | {t_fast:.2f} | {t_plain:.2f} | - | - | refused: {fast.refusal.limit.value} '
                  f'at {fast.refusal.phase} | {"MET" if t_fast < TARGET else "MISSED"} |')
            worst = max(worst, t_fast)
            continue
        same = plain.crossing is not None and plain.crossing.candidate == fast.crossing.candidate
        worst = max(worst, t_fast)
        print(f'| {label} | {fast.crossing.evaluated} | {t_fast:.2f} | {t_plain:.2f} | {t_plain / t_fast:.1f}x '
              f'| {"yes" if same else "NO"} | {fast.crossing.score:.3f} | {"MET" if t_fast < TARGET else "MISSED"} |')
    t0 = time.perf_counter()
    refused = FrameNodePlanner(g, 90, use_extra_dof=False)
    t = time.perf_counter() - t0
    what = ('planned (not refused!)' if refused.refusal is None
            else f'refused: {refused.refusal.limit.value} at {refused.refusal.phase}')
    print(f'\n90 deg in plane without the extra DOF: {what} in {t:.2f} s')
    print(f'slowest junction: {worst:.2f} s, target < {TARGET:.0f} s: {"MET" if worst < TARGET else "MISSED"}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
