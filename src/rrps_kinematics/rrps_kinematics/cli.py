"""``rrps-kinematics``: the kinematics core from the command line (no ROS needed).

Commands ``info``, ``ik``, ``fk``, ``modes`` (:mod:`.assembly`), ``workspace`` (§3.1,
:mod:`.cli_workspace`) and ``urdf`` (:mod:`rrps_description.urdf`); ``--help`` gives their
arguments, docs/usage.md ('Command-line tools') shows them. Poses are a_T_b (ring_b in ring_a's
frame), metres and (x, y, z, w) quaternions; exit statuses as :func:`.cli_support.run_command`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from rrps_description.geometry import RobotGeometry, shipped_robots
from rrps_description.pose import validate_pose
from rrps_kinematics.assembly import METHODS, PATHS, assembly_modes
from rrps_kinematics.cli_support import (
    EXIT_FAILED,
    EXIT_OK,
    OneLineParser,
    UsageError,
    checked,
    format_vector,
    join_negative_vectors,
    load_robot_or_usage_error,
    run_command,
    vector,
)
from rrps_kinematics.cli_workspace import add_workspace_arguments, workspace_report
from rrps_kinematics.forward import check_lengths, forward_kinematics
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.limits import Margins, margins
from rrps_kinematics.urdf_joints import robot_urdf

PROG = 'rrps-kinematics'
#: The kernels' backend of the one-pose commands (info, ik, fk): interpreted, they answer in
#: milliseconds; compiled, their first run where numba has no cache yet (a fresh colcon install
#: tree) compiles the limits' kernels first, a minute or more.
ONE_POSE = 'numpy'
_VECTOR_OPTIONS = ('--position', '--quaternion', '--lengths', '--seed', '--bounds', '--roll',
                   '--pitch', '--yaw')


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog=PROG,
        description='Kinematics of RRPS parallel climbing robots: robot summary, inverse and '
                    'forward kinematics, all assembly modes, reachable workspace, URDF. Poses are ring_b '
                    'in ring_a (a_T_b), SI units, quaternions (x, y, z, w).',
        epilog=f'shipped robots: {", ".join(shipped_robots())}')
    sub = parser.add_subparsers(dest='command', metavar='{info,ik,fk,modes,workspace,urdf}',
                                parser_class=OneLineParser)
    sub.required = True

    def add(name: str, help_text: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.add_argument('--robot', default='pole_climber',
                       help='shipped robot name or robot YAML path (default: pole_climber)')
        p.add_argument('--json', action='store_true', help='print JSON instead of text')
        return p

    add('info', 'robot summary: anchors, home pose, stroke, home lengths, margins at home')
    p = add('ik', 'inverse kinematics of one pose: leg lengths, joint angles, margins')
    p.add_argument('--position', type=vector(3), required=True, metavar='X,Y,Z',
                   help='ring_b origin in ring_a [m]')
    p.add_argument('--quaternion', type=vector(4), default=np.array([0, 0, 0, 1.0]),
                   metavar='QX,QY,QZ,QW', help='ring_b orientation in ring_a (default: identity)')
    p = add('fk', 'forward kinematics: the pose for six leg lengths (Newton from a seed)')
    p.add_argument('--lengths', type=vector(6), required=True, metavar='L1,...,L6',
                   help='actuator lengths [m]')
    p.add_argument('--seed', type=vector(7), metavar='X,Y,Z,QX,QY,QZ,QW',
                   help='seed pose (default: the robot\'s home pose)')
    p = add('modes', 'all assembly modes: every real pose for six leg lengths')
    p.add_argument('--lengths', type=vector(6), required=True, metavar='L1,...,L6',
                   help='actuator lengths [m]')
    p.add_argument('--method', choices=METHODS, default=METHODS[0],
                   help='continuation (default: 40 homotopy paths, certified when all end) or multistart')
    p = add('workspace', 'reachable workspace: the ring_b positions within every limit, on a grid')
    add_workspace_arguments(p)
    p = sub.add_parser('urdf', help="the robot's URDF (robot_description)",
                       description="the robot's URDF, as robot_description_node publishes it")
    p.add_argument('--robot', default='pole_climber',
                   help='shipped robot name or robot YAML path (default: pole_climber)')
    p.add_argument('--output', type=Path, metavar='FILE', help='write it to FILE (default: stdout)')
    return parser


def _margins_dict(m: Margins) -> dict[str, Any]:
    return {'within_limits': bool(m.ok), 'violations': m.violations(),
            'min_stroke_m': float(np.min(m.stroke)),
            'min_universal_rad': float(np.min(m.universal)),
            'min_spherical_rad': float(np.min(m.spherical)),
            'min_interference_m': float(np.min(m.interference)),
            'inverse_condition': float(m.inverse_condition),
            'conditioning_margin': float(m.conditioning)}


def _margin_lines(m: Margins) -> list[str]:
    d = _margins_dict(m)
    lines = [f'margins:  stroke {d["min_stroke_m"]:+.4f} m, universal {d["min_universal_rad"]:+.3f} rad, '
             f'spherical {d["min_spherical_rad"]:+.3f} rad, interference {d["min_interference_m"]:+.4f} m, '
             f'conditioning {d["conditioning_margin"]:+.4f} (1/cond {d["inverse_condition"]:.4f})',
             f'within limits: {"yes" if m.ok else "no"}']
    lines += [f'  - {v}' for v in m.violations()]
    return lines


def _info(g: RobotGeometry) -> tuple[dict, list[str]]:
    ik = inverse_kinematics(g, g.home_position, g.home_quaternion_xyzw)
    m = margins(g, ik, backend=ONE_POSE)
    data = {'name': g.name, 'description': g.description,
            'ring_a_anchors': g.ring_a_anchors.tolist(), 'ring_b_anchors': g.ring_b_anchors.tolist(),
            'home_position': g.home_position.tolist(),
            'home_quaternion_xyzw': g.home_quaternion_xyzw.tolist(),
            'home_lengths': g.home_lengths.tolist(),
            'min_length': g.min_length, 'max_length': g.max_length, 'max_speed': g.max_speed,
            'max_force': g.max_force, 'leg_radius': g.leg_radius,
            'universal_max_angle': g.universal_max_angle, 'spherical_max_angle': g.spherical_max_angle,
            'min_conditioning': g.min_conditioning, 'characteristic_length': g.characteristic_length,
            'grippers': dict(g.grippers),
            'extra_dof': {k: {'axis': v.axis.tolist(), 'min_angle': v.min_angle, 'max_angle': v.max_angle}
                          for k, v in g.extra_dof.items()},
            'margins_at_home': _margins_dict(m)}
    lines = [f'robot: {g.name}', f'  {g.description}' if g.description else '',
             'leg  ring_a anchor (U-joint) [m]          ring_b anchor (S-joint) [m]          home length [m]']
    lines = [line for line in lines if line]
    for i in range(6):
        lines.append(f'leg_{i + 1} {format_vector(g.ring_a_anchors[i], 4):36s} '
                     f'{format_vector(g.ring_b_anchors[i], 4):36s} {g.home_lengths[i]:.4f}')
    lines += [f'home pose: position {format_vector(g.home_position, 4)} m, '
              f'quaternion {format_vector(g.home_quaternion_xyzw, 4)}',
              f'stroke: {g.min_length:.4f} .. {g.max_length:.4f} m, max speed {g.max_speed} m/s, '
              f'max force {g.max_force} N, leg radius {g.leg_radius} m',
              f'joint limits: universal {g.universal_max_angle} rad, spherical {g.spherical_max_angle} rad, '
              f'min 1/cond {g.min_conditioning}',
              f'grippers: ring_a {g.grippers["ring_a"]}, ring_b {g.grippers["ring_b"]}'
              + (f'; extra ring DOF on {", ".join(sorted(g.extra_dof))}' if g.extra_dof else '')]
    lines += _margin_lines(m)
    return data, lines


def _ik(g: RobotGeometry, position: np.ndarray, quaternion: np.ndarray) -> tuple[dict, list[str]]:
    ik = inverse_kinematics(g, position, quaternion)
    m = margins(g, ik, backend=ONE_POSE)
    data = {'position': position.tolist(), 'quaternion_xyzw': (quaternion / np.linalg.norm(quaternion)).tolist(),
            'lengths': ik.lengths.tolist(), 'universal_angles': ik.universal_angles.tolist(),
            'universal_cone_angles': ik.universal_cone_angles.tolist(),
            'spherical_cone_angles': ik.spherical_cone_angles.tolist(), 'margins': _margins_dict(m)}
    lines = [f'robot: {g.name}',
             f'pose: position {format_vector(position, 4)} m, quaternion {format_vector(data["quaternion_xyzw"], 4)}',
             'leg    length [m]  U-joint angles [rad]   U cone [rad]  S cone [rad]']
    for i in range(6):
        lines.append(f'leg_{i + 1}  {ik.lengths[i]:.6f}   {format_vector(ik.universal_angles[i], 4):20s}   '
                     f'{ik.universal_cone_angles[i]:.4f}        {ik.spherical_cone_angles[i]:.4f}')
    lines.append('lengths: ' + ','.join(f'{x:.6f}' for x in ik.lengths))
    return data, lines + _margin_lines(m)


def _fk(g: RobotGeometry, lengths: np.ndarray, seed: np.ndarray | None) -> tuple[dict, list[str]]:
    seed_p = g.home_position if seed is None else seed[:3]
    seed_q = g.home_quaternion_xyzw if seed is None else seed[3:]
    fk = forward_kinematics(g, lengths, seed_p, seed_q, backend=ONE_POSE)
    m = margins(g, inverse_kinematics(g, fk.position, fk.quaternion_xyzw), backend=ONE_POSE)
    data = {'position': fk.position.tolist(), 'quaternion_xyzw': fk.quaternion_xyzw.tolist(),
            'converged': fk.converged, 'iterations': fk.iterations, 'residual': fk.residual,
            'singular': fk.singular, 'margins': _margins_dict(m)}
    status = 'converged' if fk.converged else ('singular Jacobian' if fk.singular else 'NOT converged')
    lines = [f'robot: {g.name}',
             f'{status} in {fk.iterations} iterations, residual {fk.residual:.2e} m',
             f'position   {format_vector(fk.position)} m',
             f'quaternion {format_vector(fk.quaternion_xyzw)} (x, y, z, w)']
    return data, lines + _margin_lines(m)


def _modes(g: RobotGeometry, lengths: np.ndarray, method: str) -> tuple[dict, list[str]]:
    modes = assembly_modes(g, lengths, method=method)
    ok = (margins(g, inverse_kinematics(g, modes.positions, modes.quaternions_xyzw)).ok
          if len(modes) else np.zeros(0, dtype=bool))
    data = {'count': len(modes), 'seeds': modes.seeds, 'method': modes.method, 'certified': modes.certified,
            'paths_failed': modes.paths_failed,
            'modes': [{'position': p.tolist(), 'quaternion_xyzw': q.tolist(), 'residual': float(r),
                       'within_limits': bool(k)}
                      for p, q, r, k in zip(modes.positions, modes.quaternions_xyzw, modes.residuals, ok)]}
    how = (f'by continuation, certified complete (all {PATHS} paths ended)' if modes.certified
           else f'by {modes.method}' + (f' ({modes.seeds} seeds)' if modes.seeds else '')
           + (f', NOT certified: {modes.paths_failed} of {PATHS} paths failed' if modes.paths_failed else ''))
    lines = [f'robot: {g.name}', f'{len(modes)} real assembly modes {how}, nearest to home first',
             '  #  position [m]                        quaternion (x, y, z, w)                 in limits']
    for k, (p, q) in enumerate(zip(modes.positions, modes.quaternions_xyzw)):
        lines.append(f'{k + 1:3d}  {format_vector(p, 5):34s}  {format_vector(q, 5):40s} {"yes" if ok[k] else "no"}')
    return data, lines


def _urdf(g: RobotGeometry, output: Path | None) -> list[str]:
    text = robot_urdf(g)
    if output is None:
        return [text.rstrip('\n')]
    try:
        output.write_text(text)
    except OSError as exc:
        raise UsageError(f'{output}: cannot write: {exc.strerror}') from None
    return [f'wrote {output}']


def run(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (cli_support.run_command: 0 done, 2 a
    usage error, 1 a computation that failed, 3 a bug). An FK that does not converge prints its
    result (NOT converged) and exits 1."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    failed = []

    def body() -> list[str]:
        args = parser.parse_args(join_negative_vectors(argv, _VECTOR_OPTIONS))
        g = load_robot_or_usage_error(args.robot)
        if args.command == 'urdf':
            return _urdf(g, args.output)
        if args.command == 'info':
            data, lines = _info(g)
        elif args.command == 'ik':
            p, q = checked('--position/--quaternion', validate_pose, args.position,
                           args.quaternion, tolerance=None)
            data, lines = _ik(g, p, q)
        elif args.command == 'fk':
            lengths = checked('--lengths', check_lengths, args.lengths)
            data, lines = _fk(g, lengths, args.seed)
            if not data['converged']:
                failed.append('fk')
        elif args.command == 'workspace':
            data, lines = workspace_report(g, args)
        else:
            data, lines = checked('--lengths', _modes, g,
                                  checked('--lengths', check_lengths, args.lengths), args.method)
        return [json.dumps(data, indent=2)] if args.json else lines

    status = run_command(PROG, body)
    return EXIT_FAILED if status == EXIT_OK and failed else status


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point ``rrps-kinematics``."""
    sys.exit(run(argv))


if __name__ == '__main__':
    main()
