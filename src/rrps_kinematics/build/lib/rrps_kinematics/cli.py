"""``rrps-kinematics``: the kinematics core from the command line (no ROS needed).

    rrps-kinematics info  [--robot R]
    rrps-kinematics ik    [--robot R] --position x,y,z [--quaternion qx,qy,qz,qw]
    rrps-kinematics fk    [--robot R] --lengths l1,...,l6 [--seed x,y,z,qx,qy,qz,qw]
    rrps-kinematics modes [--robot R] --lengths l1,...,l6 [--method continuation|multistart]
    rrps-kinematics workspace [--robot R] [--quaternion qx,qy,qz,qw] [--resolution h]
        [--bounds xmin,xmax,ymin,ymax,zmin,zmax] [--roll a,b] [--pitch a,b] [--yaw a,b]
        [--angle-step d] [--singular-threshold t] [--csv out.csv] [--near-singular-csv f.csv]
        [--png out.png]
    rrps-kinematics urdf  [--robot R] [--output FILE]

``--robot`` takes a shipped robot name (default ``pole_climber``) or a YAML path; ``--json``
prints machine-readable output. Poses are a_T_b (ring_b in ring_a's frame), metres and ROS
(x, y, z, w) quaternions. Exit status: 0 done, 1 ``fk`` did not converge (the result is still
printed), 2 bad arguments or robot file (one error line on stderr).

``workspace`` (paper section 3.1, :mod:`rrps_kinematics.workspace`): the ring_b positions within
every limit at the orientation ``--quaternion`` (default: home), or at every orientation of the
range R = Rz(yaw) Ry(pitch) Rx(roll) R(quaternion) given by ``--roll/--pitch/--yaw`` intervals
[rad] sampled every ``--angle-step`` [rad]. ``--csv`` gets every reachable point (header
``x,y,z``, metres in ring_a, near-singular points included); the near-singular ones (inverse
condition number below ``--singular-threshold``) also go to a second CSV, by default next to the
first with ``_near_singular`` added to its name. ``--png`` draws three orthogonal slices through
the home position.

``modes`` (:mod:`rrps_kinematics.assembly`): every real pose for the lengths, by continuation
(default; the output says whether all 40 paths were tracked, i.e. the list is certified
complete) or by the multi-start search.

``urdf`` (:mod:`rrps_description.urdf`): the robot's URDF, as robot_description_node publishes
it, on stdout or to ``--output``.
"""

from __future__ import annotations

import argparse
import json
import math
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
    join_negative_vectors,
    load_robot_or_usage_error,
    positive,
    run_command,
    vector,
)
from rrps_kinematics.errors import ComputationError
from rrps_kinematics.forward import check_lengths, forward_kinematics
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.limits import Margins, margins
from rrps_kinematics.urdf_joints import robot_urdf
from rrps_kinematics.workspace import (
    LIMIT_KINDS,
    NEAR_SINGULAR,
    REACHABLE,
    SINGULAR_THRESHOLD,
    Workspace,
    distance_to_boundary,
    orientation_range,
    reachable_workspace,
)

PROG = 'rrps-kinematics'
_VECTOR_OPTIONS = ('--position', '--quaternion', '--lengths', '--seed', '--bounds', '--roll',
                   '--pitch', '--yaw')
#: Default workspace grid spacing: the robot's stroke divided by this.
STROKE_CELLS = 25
#: Default angle step of an orientation range [rad].
ANGLE_STEP = 0.05


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
    p.add_argument('--quaternion', type=vector(4), metavar='QX,QY,QZ,QW',
                   help='ring_b orientation in ring_a (default: the home orientation)')
    p.add_argument('--resolution', type=positive, metavar='H',
                   help=f'grid spacing [m] (default: the stroke / {STROKE_CELLS})')
    p.add_argument('--bounds', type=vector(6), metavar='XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX',
                   help='grid bounds in ring_a [m] (default: from the stroke and the '
                        'universal-joint cones)')
    for name in ('roll', 'pitch', 'yaw'):
        p.add_argument(f'--{name}', type=vector(2), metavar='MIN,MAX',
                       help=f'{name} range [rad] about ring_a\'s fixed axis: a point is reachable '
                            'when it is at every sampled orientation (default: 0,0)')
    p.add_argument('--angle-step', type=positive, default=ANGLE_STEP, metavar='D',
                   help=f'largest step between sampled angles [rad] (default: {ANGLE_STEP})')
    p.add_argument('--singular-threshold', type=float, default=SINGULAR_THRESHOLD, metavar='T',
                   help='inverse condition number below which a reachable point is near-singular '
                        f'(default: {SINGULAR_THRESHOLD}, the teleop slow-down threshold)')
    p.add_argument('--csv', type=Path, metavar='PATH', help='write the reachable points (x,y,z)')
    p.add_argument('--near-singular-csv', type=Path, metavar='PATH',
                   help='write the near-singular points (default with --csv: its name + '
                        '_near_singular)')
    p.add_argument('--png', type=Path, metavar='PATH', help='draw three orthogonal slices')
    p = sub.add_parser('urdf', help="the robot's URDF (robot_description)",
                       description="the robot's URDF, as robot_description_node publishes it")
    p.add_argument('--robot', default='pole_climber',
                   help='shipped robot name or robot YAML path (default: pole_climber)')
    p.add_argument('--output', type=Path, metavar='FILE', help='write it to FILE (default: stdout)')
    return parser


def _fmt(v: Any, digits: int = 6) -> str:
    return '[' + ', '.join(f'{x:.{digits}f}' for x in np.ravel(v)) + ']'


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
    m = margins(g, ik)
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
        lines.append(f'leg_{i + 1} {_fmt(g.ring_a_anchors[i], 4):36s} {_fmt(g.ring_b_anchors[i], 4):36s} '
                     f'{g.home_lengths[i]:.4f}')
    lines += [f'home pose: position {_fmt(g.home_position, 4)} m, quaternion {_fmt(g.home_quaternion_xyzw, 4)}',
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
    m = margins(g, ik)
    data = {'position': position.tolist(), 'quaternion_xyzw': (quaternion / np.linalg.norm(quaternion)).tolist(),
            'lengths': ik.lengths.tolist(), 'universal_angles': ik.universal_angles.tolist(),
            'universal_cone_angles': ik.universal_cone_angles.tolist(),
            'spherical_cone_angles': ik.spherical_cone_angles.tolist(), 'margins': _margins_dict(m)}
    lines = [f'robot: {g.name}', f'pose: position {_fmt(position, 4)} m, quaternion {_fmt(data["quaternion_xyzw"], 4)}',
             'leg    length [m]  U-joint angles [rad]   U cone [rad]  S cone [rad]']
    for i in range(6):
        lines.append(f'leg_{i + 1}  {ik.lengths[i]:.6f}   {_fmt(ik.universal_angles[i], 4):20s}   '
                     f'{ik.universal_cone_angles[i]:.4f}        {ik.spherical_cone_angles[i]:.4f}')
    lines.append('lengths: ' + ','.join(f'{x:.6f}' for x in ik.lengths))
    return data, lines + _margin_lines(m)


def _fk(g: RobotGeometry, lengths: np.ndarray, seed: np.ndarray | None) -> tuple[dict, list[str]]:
    seed_p = g.home_position if seed is None else seed[:3]
    seed_q = g.home_quaternion_xyzw if seed is None else seed[3:]
    fk = forward_kinematics(g, lengths, seed_p, seed_q)
    m = margins(g, inverse_kinematics(g, fk.position, fk.quaternion_xyzw))
    data = {'position': fk.position.tolist(), 'quaternion_xyzw': fk.quaternion_xyzw.tolist(),
            'converged': fk.converged, 'iterations': fk.iterations, 'residual': fk.residual,
            'singular': fk.singular, 'margins': _margins_dict(m)}
    status = 'converged' if fk.converged else ('singular Jacobian' if fk.singular else 'NOT converged')
    lines = [f'robot: {g.name}',
             f'{status} in {fk.iterations} iterations, residual {fk.residual:.2e} m',
             f'position   {_fmt(fk.position)} m', f'quaternion {_fmt(fk.quaternion_xyzw)} (x, y, z, w)']
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
        lines.append(f'{k + 1:3d}  {_fmt(p, 5):34s}  {_fmt(q, 5):40s} {"yes" if ok[k] else "no"}')
    return data, lines


def _write_points(path: Path, points: np.ndarray) -> None:
    try:
        np.savetxt(path, points, fmt='%.6f', delimiter=',', header='x,y,z', comments='')
    except OSError as exc:
        raise UsageError(f'{path}: cannot write: {exc.strerror}') from None


def _write_slices(ws: Workspace, centre: np.ndarray, path: Path, title: str) -> None:
    """Three orthogonal slices of the grid through the point nearest ``centre``, coloured by class."""
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    colours = ('#d9d9d9', '#2ca02c', '#ff7f0e')
    k = np.clip(np.round((centre - ws.origin) / ws.spacing).astype(int), 0, np.array(ws.shape) - 1)
    axes = ws.axes
    h = ws.spacing
    fig = Figure(figsize=(14, 5), layout='constrained')
    panels = fig.subplots(1, 3)
    for ax, (a, b, c) in zip(panels, ((0, 1, 2), (0, 2, 1), (1, 2, 0))):
        image = np.take(ws.labels, k[c], axis=c)  # rows: axis a, columns: axis b
        ax.imshow(image.T, origin='lower', cmap=ListedColormap(colours), vmin=0, vmax=2,
                  interpolation='nearest', extent=(axes[a][0] - h / 2, axes[a][-1] + h / 2,
                                                   axes[b][0] - h / 2, axes[b][-1] + h / 2))
        ax.plot(centre[a], centre[b], 'k+', markersize=12)
        ax.set_xlabel(f'{"xyz"[a]} [m]')
        ax.set_ylabel(f'{"xyz"[b]} [m]')
        ax.set_title(f'{"xyz"[c]} = {axes[c][k[c]]:.4f} m')
        ax.set_aspect('equal')
    fig.legend(handles=[Patch(color=colours[0], label='unreachable'),
                        Patch(color=colours[REACHABLE], label='reachable'),
                        Patch(color=colours[NEAR_SINGULAR],
                              label=f'near-singular (1/cond < {ws.singular_threshold:g})')],
               loc='outside lower center', ncols=3)
    fig.suptitle(title)
    try:
        fig.savefig(path, dpi=100)
    except OSError as exc:
        raise UsageError(f'{path}: cannot write: {exc.strerror}') from None


def _workspace(g: RobotGeometry, args: argparse.Namespace) -> tuple[dict, list[str]]:
    resolution = args.resolution
    if resolution is None:
        if not math.isfinite(g.max_length):
            raise UsageError(f'{g.name}: the stroke is unbounded: give --resolution and --bounds')
        resolution = (g.max_length - g.min_length) / STROKE_CELLS
    q0 = g.home_quaternion_xyzw if args.quaternion is None else args.quaternion
    ranges = {name: getattr(args, name) for name in ('roll', 'pitch', 'yaw')
              if getattr(args, name) is not None}
    orientations = (_checked('orientation range', orientation_range, q0, step=args.angle_step,
                             **ranges) if ranges else q0)
    ws = _checked('workspace', reachable_workspace, g, orientations, resolution=resolution,
                  bounds=args.bounds, singular_threshold=args.singular_threshold)
    counts = ws.counts
    kind = 'total-orientation' if ranges else 'constant-orientation'
    near_csv = args.near_singular_csv
    if near_csv is None and args.csv is not None:
        near_csv = args.csv.with_name(f'{args.csv.stem}_near_singular{args.csv.suffix}')
    data = {'robot': g.name, 'workspace': kind,
            'quaternion_xyzw': (np.asarray(q0) / np.linalg.norm(q0)).tolist(),
            'ranges_rad': {name: r.tolist() for name, r in ranges.items()},
            'angle_step_rad': args.angle_step if ranges else None,
            'orientations': len(ws.orientations), 'resolution_m': resolution,
            'shape': list(ws.shape), 'bounds_m': ws.bounds.tolist(),
            'grid_points': counts['total'], 'reachable_points': counts['reachable'],
            'near_singular_points': counts['near_singular'],
            'unreachable_points': counts['unreachable'], 'volume_m3': ws.volume,
            'near_singular_volume_m3': ws.near_singular_volume,
            'singular_threshold': ws.singular_threshold, 'excluded_by': ws.excluded_by,
            'home_distance_to_boundary_m': distance_to_boundary(ws, g.home_position),
            'csv': None if args.csv is None else str(args.csv),
            'near_singular_csv': None if near_csv is None else str(near_csv),
            'png': None if args.png is None else str(args.png)}
    if ranges:
        spans = ', '.join(f'{name} [{r[0]:g}, {r[1]:g}]' for name, r in ranges.items())
        orientation = (f'{len(ws.orientations)} orientations: {spans} rad every <= {args.angle_step:g} '
                       f'rad about quaternion {_fmt(data["quaternion_xyzw"], 4)}')
    else:
        orientation = f'quaternion {_fmt(data["quaternion_xyzw"], 4)}'
    b = ws.bounds
    lines = [f'robot: {g.name}', f'{kind} workspace, {orientation}',
             f'grid: {" x ".join(str(n) for n in ws.shape)} = {counts["total"]:,} points, spacing '
             f'{resolution:.4g} m, x [{b[0]:.4f}, {b[1]:.4f}] y [{b[2]:.4f}, {b[3]:.4f}] '
             f'z [{b[4]:.4f}, {b[5]:.4f}] m',
             f'reachable: {counts["reachable"]:,} points, volume {ws.volume:.6g} m^3',
             f'near-singular (1/cond < {ws.singular_threshold:g}): {counts["near_singular"]:,} points, '
             f'volume {ws.near_singular_volume:.6g} m^3 (part of the reachable set)',
             f'unreachable: {counts["unreachable"]:,} points; first limit broken: '
             + ', '.join(f'{k} {ws.excluded_by[k]:,}' for k in LIMIT_KINDS),
             f'home position: distance to the boundary {data["home_distance_to_boundary_m"]:+.4f} m']
    if args.csv is not None:
        _write_points(args.csv, ws.reachable)
        lines.append(f'wrote {args.csv} (reachable points, x,y,z)')
    if near_csv is not None:
        _write_points(near_csv, ws.near_singular)
        lines.append(f'wrote {near_csv} (near-singular points, x,y,z)')
    if args.png is not None:
        _write_slices(ws, np.asarray(g.home_position), args.png,
                      f'{g.name}: {kind} workspace, {ws.volume:.4g} m^3 at {resolution:.4g} m')
        lines.append(f'wrote {args.png}')
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


def _checked(what: str, check, *args, **kwargs):
    """Validate a command-line input with the core's own check: its ValueError is a usage error."""
    try:
        return check(*args, **kwargs)
    except ComputationError:
        raise
    except ValueError as exc:
        raise UsageError(f'{what}: {exc}') from None


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
            p, q = _checked('--position/--quaternion', validate_pose, args.position,
                            args.quaternion, tolerance=None)
            data, lines = _ik(g, p, q)
        elif args.command == 'fk':
            lengths = _checked('--lengths', check_lengths, args.lengths)
            data, lines = _fk(g, lengths, args.seed)
            if not data['converged']:
                failed.append('fk')
        elif args.command == 'workspace':
            data, lines = _workspace(g, args)
        else:
            data, lines = _checked('--lengths', _modes, g,
                                   _checked('--lengths', check_lengths, args.lengths), args.method)
        return [json.dumps(data, indent=2)] if args.json else lines

    status = run_command(PROG, body)
    return EXIT_FAILED if status == EXIT_OK and failed else status


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point ``rrps-kinematics``."""
    sys.exit(run(argv))


if __name__ == '__main__':
    main()
