#!/usr/bin/env python3
"""Benchmark of the climb planner's load check, against baselines in the same run.

    python benchmarks/plan_loads.py [--repeat 3]

For each shipped climbing robot on its structure, an ordinary climb is planned (best CPU time
of ``--repeat`` runs, ``time.process_time``):

* ``plan, no loads``: ``GaitPlanner(..., loads=None)``, every kinematic limit checked;
* ``plan + loads``: the default planner, which also times every motion within the loads
  (``rrps_climbing.load_check``: the loads' coefficients at the timing's gridpoints,
  ``rrps_loads.path_loads.loads_at`` once per motion); ``load check``: that timing and check alone;
* baseline ``loads per pose``: the loads of the timed motions at their samples every 20 ms
  (the climb node's stream), one pose at a time in a Python loop, their twists from the timing
  law, and the largest difference of their forces from the check's at the same samples.

Target: the load check (timing included) at least 5x faster than the per-pose loop (MET/MISSED).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.load_check import LoadCheck
from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_multiply_xyzw
from rrps_description.structures import make_structure
from rrps_loads.path_loads import _supporting_wrench
from rrps_loads.reduced import PlatformPose, generalized_forces
from rrps_loads.statics import solve_actuator_forces
from rrps_loads.support import support_of

CASES = [('pole_climber', 'pole', 1.0), ('pole_climber', 'palm_trunk', 1.0),
         ('frame_climber', 'frame', 2.0), ('facade_climber', 'facade', 1.5)]
TARGET = 5.0


def best(fn, repeat: int) -> tuple[object, float]:
    out, times = None, []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return out, min(times)


def per_pose(geometry, check: LoadCheck, phases, period=0.02) -> tuple[np.ndarray, np.ndarray]:
    """Baseline: the loads of every timed motion at its samples every ``period``, one pose at a
    time; (forces (n, 6), the check's forces at the same samples (n, 6))."""
    forces, checked = [], []
    for ph in phases:
        if ph.timing is None or ph.gripper_a == ph.gripper_b:
            continue
        ring = 'ring_a' if ph.gripper_a else 'ring_b'
        world_T = ph.world_T_a if ring == 'ring_a' else ph.world_T_b
        support = support_of(ring, quat_multiply_xyzw(np.asarray(check.world_q_structure), world_T.quaternion_xyzw),
                             check.gravity)
        offset = 0.0
        for curve, law in ph.timing.pieces:
            t = np.arange(0.0, law.duration, period)
            s, sd, sdd = law.evaluate(t)
            p, q, T1, T2 = curve.twists(s)
            twist, rate = T1 * sd[:, None], T1 * sdd[:, None] + T2 * sd[:, None] ** 2
            for k in range(len(t)):
                pose = PlatformPose(geometry, p[k], q[k], support)
                forces.append(solve_actuator_forces(pose, generalized_forces(pose, twist[k:k + 1], rate[k:k + 1]))[0])
                _supporting_wrench(pose, twist[k:k + 1], rate[k:k + 1])
            index = np.clip(np.searchsorted(ph.timing.load_times, offset + t), 0, len(ph.timing.load_times) - 1)
            checked.append(ph.timing.loads.actuator_forces[index])
            offset += law.duration
    return np.array(forces), np.concatenate(checked)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--repeat', type=int, default=3)
    args = parser.parse_args(argv)
    print(f'{"robot":15s} {"structure":10s} {"phases":>6s} {"poses":>6s} {"plan, no loads":>15s} '
          f'{"plan + loads":>13s} {"load check":>11s} {"loads per pose":>15s} {"speed-up":>9s} '
          f'{"max |df| N":>10s}  verdict')
    verdicts = []
    for robot, name, distance in CASES:
        g = load_robot(robot)
        structure = make_structure(name, distance + 1.5 * g.max_length + 0.3)
        check = LoadCheck()
        bare, t_bare = best(lambda: GaitPlanner(g, structure, loads=None).plan(distance), args.repeat)
        plan, t_loads = best(lambda: GaitPlanner(g, structure, loads=check).plan(distance), args.repeat)
        _, t_check = best(lambda: check.check(g, bare.phases), args.repeat)
        (loop, vectorised), t_loop = best(lambda: per_pose(g, check, plan.phases), args.repeat)
        poses = len(loop)
        speed_up = t_loop / t_check
        verdict = 'MET' if speed_up >= TARGET else 'MISSED'
        verdicts.append(verdict)
        print(f'{robot:15s} {name:10s} {len(plan.phases):6d} {poses:6d} {t_bare * 1e3:12.1f} ms '
              f'{t_loads * 1e3:10.1f} ms {t_check * 1e3:8.1f} ms {t_loop * 1e3:12.1f} ms {speed_up:8.1f}x '
              f'{np.abs(loop - vectorised).max():10.2e}  {verdict}')
    print(f'target: the vectorised load check >= {TARGET:.0f}x faster than the per-pose loop: '
          f'{"MET" if all(v == "MET" for v in verdicts) else "MISSED"}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
