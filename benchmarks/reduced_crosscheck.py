#!/usr/bin/env python3
"""Cross-check of the two dynamics formulations, printed as a table.

    python benchmarks/reduced_crosscheck.py [--robot pole_climber ...] [--method hybrid ...]
        [--support ring_a|ring_b] [--support-quaternion QX,QY,QZ,QW]

For every robot: the paper's 0.5 s constant-force run (at rest at an off-home pose, the holding
forces plus a constant push sized so that ring_b's initial acceleration would carry it 6 % of
the robot's size) on the reduced 6-DOF model (rrps_loads.reduced, DOP853) and on the 91-coordinate
multibody DAE (rrps_sim.dynamics, dt = 1 ms), and the holding forces of both at three poses.
Columns: ring_b's displacement, the largest differences of position, orientation, leg length and
kinetic energy along the run, of the holding forces, and the wall time of each model.
Both models ground the ``--support`` ring, turned by ``--support-quaternion`` in the world.
Targets: positions <= 1e-6 m and statics <= 1e-6 N.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rrps_description.geometry import load_robot, shipped_robots
from rrps_description.rotations import quat_conjugate_xyzw, quat_multiply_xyzw, rotation_vector_to_quat_xyzw
from rrps_loads.reduced import PlatformPose, platform_accelerations, simulate_reduced
from rrps_loads.statics import holding_forces
from rrps_loads.support import support_of
from rrps_sim.dynamics import METHODS, MultibodyDynamics, simulate

POSES = (([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]), ([0.06, -0.03, 0.05], [0.06, -0.04, 0.1]),
         ([-0.05, 0.07, -0.04], [-0.12, 0.08, -0.15]))


def _pose(geom, dp, rv):
    p = geom.home_position + geom.characteristic_length * np.asarray(dp)
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.asarray(rv)), geom.home_quaternion_xyzw)
    return p, q


def constant_force_run(geom, world):
    p0, q0 = _pose(geom, *POSES[1])
    hold = holding_forces(geom, p0, q0, support=world)
    pattern = np.array([1.5, -1.0, 0.5, 1.0, -0.5, 0.8])
    acc = platform_accelerations(PlatformPose(geom, p0, q0, world), np.zeros((1, 6)),
                                 (hold + pattern)[None])[0, :3]
    reach = 0.06 * geom.characteristic_length
    return p0, q0, hold + pattern * (reach / (0.5 * 0.5**2 * np.linalg.norm(acc)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robot', nargs='+', default=shipped_robots())
    parser.add_argument('--method', nargs='+', default=list(METHODS), choices=METHODS)
    parser.add_argument('--support', default='ring_a', choices=('ring_a', 'ring_b'))
    parser.add_argument('--support-quaternion', type=lambda text: [float(v) for v in text.split(',')],
                        default=None, metavar='QX,QY,QZ,QW')
    args = parser.parse_args()
    world = support_of(args.support, args.support_quaternion)
    header = (f'{"robot":<15} {"method":<13} {"moved m":>8} {"d pos m":>9} {"d rot rad":>9} '
              f'{"d len m":>9} {"d T J":>9} {"d stat N":>9} {"reduced s":>9} {"DAE s":>7}')
    print(header)
    print('-' * len(header))
    worst_position, worst_statics = 0.0, 0.0
    for robot in args.robot:
        geom = load_robot(robot)
        statics = max(np.abs(holding_forces(geom, p, q, support=world)
                             - MultibodyDynamics(geom, support=world).holding_forces(p, q)).max()
                      for p, q in (_pose(geom, dp, rv) for dp, rv in POSES))
        p0, q0, f = constant_force_run(geom, world)
        start = time.perf_counter()
        red = simulate_reduced(geom, p0, q0, f, 0.5, 0.001, support=world)
        t_reduced = time.perf_counter() - start
        for method in args.method:
            simulate(geom, p0, q0, f, duration=0.01, dt=0.001, method=method, support=world)  # warm up
            start = time.perf_counter()
            mb = simulate(geom, p0, q0, f, duration=0.5, dt=0.001, method=method, support=world)
            t_dae = time.perf_counter() - start
            turn = quat_multiply_xyzw(quat_conjugate_xyzw(red.quaternion_xyzw), mb.quaternion_xyzw)
            d_rot = 2 * np.arctan2(np.linalg.norm(turn[:, :3], axis=1), np.abs(turn[:, 3])).max()
            d_pos = np.abs(mb.position - red.position).max()
            worst_position, worst_statics = max(worst_position, d_pos), max(worst_statics, statics)
            print(f'{robot:<15} {method:<13} {np.linalg.norm(red.position[-1] - p0):8.4f} '
                  f'{d_pos:9.1e} {d_rot:9.1e} '
                  f'{np.abs(mb.lengths - red.lengths).max():9.1e} '
                  f'{np.abs(mb.kinetic - red.kinetic_energy).max():9.1e} {statics:9.1e} '
                  f'{t_reduced:9.3f} {t_dae:7.3f}')
    verdict = 'PASS' if worst_position <= 1e-6 and worst_statics <= 1e-6 else 'FAIL'
    print(f'\nworst position difference {worst_position:.2e} m, statics {worst_statics:.2e} N '
          f'(targets 1e-6 m, 1e-6 N): {verdict}')


if __name__ == '__main__':
    main()
