#!/usr/bin/env python3
"""Benchmark of the climbing step's preview: how many times faster than real time a whole step is
simulated on the 13-body DAE (target: at least 5x).

    python benchmarks/preview.py [--period 0.02] [--baseline 2.0]

For the pole, frame and facade climbers on their structures, one step of the planner's default
length is planned and previewed as climb_node previews it (:func:`rrps_climbing.step_preview
.run_preview`: the legs driven as the driver drives them, at the driver's 1 ms step, the support
switched at each hand-over). Speed = simulated robot time / wall time (and / CPU time of this
process: the 2 cores are shared). Same-run baseline: the plain ``simulate()`` at the same 1 ms
step with the same drives written as a Python force callback (the driver's PD and feed-forward,
the reactions every 20 ms) on the step's first motion, for ``--baseline`` s of robot time.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.step_preview import PreviewConfig, preview_motions, run_preview
from rrps_description.geometry import load_robot
from rrps_description.structures import make_structure
from rrps_kinematics import inverse_kinematics
from rrps_loads.statics import holding_forces
from rrps_sim.dynamics import simulate
from rrps_sim.preview import Drives

TARGET = 5.0
CASES = (('pole_climber', 'pole'), ('frame_climber', 'frame'), ('facade_climber', 'facade'))


def _baseline(geometry, motion, seconds: float, dt: float = 0.001) -> float:
    """Real-time multiple of plain simulate() with the drives as a Python force callback."""
    drives = Drives()
    commands = inverse_kinematics(geometry, motion.positions, motion.quaternions).lengths
    support = dict(support=motion.support, world_q_support=motion.world_q_support)
    state = {'ff': holding_forces(geometry, motion.positions[0], motion.quaternions[0], **support),
             'since': 0.0}

    def forces(t, dyn):
        if state['since'] >= drives.feedforward_period:
            state['ff'] = holding_forces(geometry, dyn.position, dyn.quaternion_xyzw, **support)
            state['since'] = 0.0
        state['since'] += dt
        target = commands[min(int(t / motion.period), len(commands) - 1)]
        f = state['ff'] + drives.kp * (target - dyn.lengths) - drives.kd * dyn.length_rates
        return np.clip(f, -geometry.max_force, geometry.max_force)

    start = time.perf_counter()
    simulate(geometry, motion.positions[0], motion.quaternions[0], forces, duration=seconds, dt=dt,
             output_every=20, reactions=True, **support)
    return seconds / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--period', type=float, default=0.02, help='command period [s] (climb_node default)')
    parser.add_argument('--baseline', type=float, default=2.0, help='robot time of the baseline run [s]')
    args = parser.parse_args()
    rows = []
    for robot, structure in CASES:
        g = load_robot(robot)
        planner = GaitPlanner(g, make_structure(structure))
        plan = planner.plan(planner.default_step, 1)
        motions = preview_motions(plan.phases, period=args.period)   # the timed motions, as streamed
        run_preview(g, plan.phases[:3], period=args.period)       # loaded once
        cpu = time.process_time()
        p = run_preview(g, plan.phases, period=args.period, config=PreviewConfig())
        cpu = time.process_time() - cpu
        base = _baseline(g, motions[0], args.baseline)
        speed = p.simulated / p.wall
        rows.append((f'{robot} / {structure}', f'{plan.step_length * 1e3:.0f} mm, {len(motions)} motions',
                     f'{p.simulated:.1f}', f'{p.wall:.2f}', f'{speed:.1f}x', f'{p.simulated / cpu:.1f}x',
                     f'{base:.1f}x', f'{p.peak_force:.1f} N (leg_{p.peak_leg})', f'{p.min_margin:.3f}',
                     'MET' if speed >= TARGET else 'MISSED'))
    head = ('robot / structure', 'step', 'simulated [s]', 'wall [s]', 'preview', 'per CPU s',
            'baseline simulate()', 'peak force', 'min margin', f'>= {TARGET:g}x')
    widths = [max(len(str(r[i])) for r in rows + [head]) for i in range(len(head))]
    for r in [head] + rows:
        print(' | '.join(str(c).ljust(w) for c, w in zip(r, widths)))


if __name__ == '__main__':
    main()
