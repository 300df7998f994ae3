"""The ``rrps-kinematics workspace`` command (paper section 3.1, :mod:`rrps_kinematics.workspace`):
its arguments, its report (volumes, counts, the first limit broken, the home position's distance
to the boundary), the reachable and near-singular points as CSV and three slices as PNG."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.cli_support import UsageError, checked, format_vector, positive, vector
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

__all__ = ['add_workspace_arguments', 'workspace_report', 'STROKE_CELLS', 'ANGLE_STEP']

#: Default workspace grid spacing: the robot's stroke divided by this.
STROKE_CELLS = 25
#: Default angle step of an orientation range [rad].
ANGLE_STEP = 0.05


def add_workspace_arguments(p: argparse.ArgumentParser) -> None:
    """The ``workspace`` command's own arguments."""
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


def workspace_report(g: RobotGeometry, args: argparse.Namespace) -> tuple[dict, list[str]]:
    """Run ``workspace`` on robot ``g``: its JSON data and its text lines; the files it writes."""
    resolution = args.resolution
    if resolution is None:
        if not math.isfinite(g.max_length):
            raise UsageError(f'{g.name}: the stroke is unbounded: give --resolution and --bounds')
        resolution = (g.max_length - g.min_length) / STROKE_CELLS
    q0 = g.home_quaternion_xyzw if args.quaternion is None else args.quaternion
    ranges = {name: getattr(args, name) for name in ('roll', 'pitch', 'yaw')
              if getattr(args, name) is not None}
    orientations = (checked('orientation range', orientation_range, q0, step=args.angle_step,
                            **ranges) if ranges else q0)
    ws = checked('workspace', reachable_workspace, g, orientations, resolution=resolution,
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
                       f'rad about quaternion {format_vector(data["quaternion_xyzw"], 4)}')
    else:
        orientation = f'quaternion {format_vector(data["quaternion_xyzw"], 4)}'
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
