"""``rrps-dynamics``: multibody dynamics, statics and the paper's cost figures (Figures 6 and 7).

Subcommands ``simulate``, ``statics``, ``inverse`` and ``report``; the world and load options are
:mod:`rrps_sim.cli_world`'s. Poses are a_T_b, SI units, ROS (x, y, z, w) quaternions; forces push
the rings apart when positive. Usage, file formats and exit status: docs/usage.md,
'Command-line tools'.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Sequence

import numpy as np

from rrps_description.geometry import RobotGeometry, shipped_robots
from rrps_kinematics.cli_support import (
    OneLineParser,
    UsageError,
    count,
    format_vector,
    join_negative_vectors,
    load_robot_or_usage_error,
    positive,
    run_command,
    vector,
)
from rrps_sim.cli_world import (
    REACTION_COLUMNS,
    WORLD_VECTOR_OPTIONS,
    add_world_options,
    reaction_rows,
    statics_json,
    statics_lines,
    with_loads,
    world_of,
)
from rrps_sim.dynamics import METHODS, MultibodyDynamics, SimulationResult, simulate
from rrps_sim.figures import figure6, figure7, plot_simulation

PROG = 'rrps-dynamics'
_VECTOR_OPTIONS = ('--position', '--quaternion', '--forces') + WORLD_VECTOR_OPTIONS
SIMULATION_COLUMNS = (['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw']
                      + [f'L{i}' for i in range(1, 7)] + [f'Ldot{i}' for i in range(1, 7)]
                      + [f'F{i}' for i in range(1, 7)]
                      + ['constraint_drift', 'euler_norm_error', 'energy_balance', 'kinetic',
                         'potential', 'actuator_work', 'step_flops', 'step_seconds'])
TRAJECTORY_COLUMNS = ('t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw')
VELOCITY_COLUMNS = ('vx', 'vy', 'vz', 'wx', 'wy', 'wz')
ACCELERATION_COLUMNS = ('ax', 'ay', 'az', 'dwx', 'dwy', 'dwz')


def _forces(text: str):
    return 'hold' if text.strip() == 'hold' else vector(6)(text)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog=PROG,
        description='Multibody dynamics of RRPS parallel climbing robots (13 bodies, 91 '
                    'coordinates, DAE of eqs. 19-20): simulate, statics, inverse dynamics and the '
                    "paper's cost figures. Poses are ring_b in ring_a (a_T_b), SI units, "
                    'quaternions (x, y, z, w); forces > 0 push the rings apart.',
        epilog=f'shipped robots: {", ".join(shipped_robots())}')
    sub = parser.add_subparsers(dest='command', metavar='{simulate,statics,inverse,report}',
                                parser_class=OneLineParser)
    sub.required = True

    def robot(p):
        p.add_argument('--robot', default='pole_climber',
                       help='shipped robot name or robot YAML path (default: pole_climber)')

    def pose(p):
        p.add_argument('--position', type=vector(3), metavar='x,y,z',
                       help='ring_b position in ring_a [m] (default: home)')
        p.add_argument('--quaternion', type=vector(4), metavar='qx,qy,qz,qw',
                       help='ring_b orientation (default: home)')

    p = sub.add_parser('simulate', help='constant actuator forces from rest; CSV (and plot) out')
    robot(p)
    pose(p)
    p.add_argument('--forces', type=_forces, required=True, metavar='f1,...,f6|hold',
                   help="constant actuator forces [N], or 'hold' for the holding forces")
    p.add_argument('--duration', type=positive, default=0.5, help='[s] (default 0.5)')
    p.add_argument('--dt', type=positive, default=0.001, help='RK4 step [s] (default 0.001)')
    p.add_argument('--method', choices=METHODS, default='hybrid',
                   help='DAE integrator (default: hybrid, as in the paper)')
    p.add_argument('--output-every', type=count, default=1, metavar='N',
                   help='write every N-th step (default 1)')
    p.add_argument('--npz', type=Path, help='output NumPy archive, one array per column')
    p.add_argument('--csv', type=Path, help='output CSV, one row per output step')
    p.add_argument('--plot', type=Path, help='output PNG of the run')
    p.add_argument('--reactions', action='store_true',
                   help="add the joint reactions and the support's wrench to the output")
    add_world_options(p)

    p = sub.add_parser('statics', help='actuator forces, joint reactions and the support holding a pose')
    robot(p)
    pose(p)
    p.add_argument('--json', action='store_true', help='print everything as one JSON object')
    add_world_options(p)

    p = sub.add_parser('inverse', help='actuator forces along a pose trajectory')
    robot(p)
    p.add_argument('--trajectory', required=True, type=Path,
                   help='CSV with columns t,x,y,z,qx,qy,qz,qw (a header row), optionally '
                        f'{",".join(VELOCITY_COLUMNS)} and {",".join(ACCELERATION_COLUMNS)}')
    p.add_argument('--csv', required=True, type=Path, help='output CSV: t,F1..F6')
    add_world_options(p)

    p = sub.add_parser('report', help="the paper's Figures 6 and 7: PNG plots and tables")
    robot(p)
    p.add_argument('--out-dir', type=Path, default=Path('.'), help='where the PNGs go (default .)')
    p.add_argument('--method', choices=METHODS, default='hybrid')
    p.add_argument('--duration', type=positive, default=0.5)
    p.add_argument('--dt', type=positive, default=0.001)
    return parser


# --- helpers --------------------------------------------------------------------------------

def _pose(g: RobotGeometry, args) -> tuple[np.ndarray, np.ndarray]:
    position = g.home_position if args.position is None else args.position
    quat = g.home_quaternion_xyzw if args.quaternion is None else args.quaternion
    if np.linalg.norm(quat) < 1e-12:
        raise UsageError('--quaternion: zero quaternion')
    return np.asarray(position, dtype=float), np.asarray(quat, dtype=float) / np.linalg.norm(quat)


class _Progress:
    """Progress on stderr: a refreshed line on a terminal, every 10 % otherwise."""

    def __init__(self, label: str):
        self.label = label
        self.tty = sys.stderr.isatty()
        self.last = 0

    def __call__(self, fraction: float) -> None:
        pct = int(100 * fraction)
        if self.tty:
            if pct != self.last:
                print(f'\r{PROG}: {self.label} {pct:3d} %', end='', file=sys.stderr, flush=True)
                if pct == 100:
                    print(file=sys.stderr)
        elif pct // 10 != self.last // 10 or (pct == 100 and self.last != 100):
            print(f'{PROG}: {self.label} {pct} %', file=sys.stderr, flush=True)
        self.last = pct


@contextmanager
def _writing(path: Path):
    """An output file that cannot be written is a usage error (a bad path on the command line)."""
    try:
        yield path
    except OSError as exc:
        raise UsageError(f'{path}: cannot write: {exc.strerror}') from None


def _write_csv(path: Path, header: Sequence[str], rows: np.ndarray) -> None:
    """A header row, then each value as ``repr(float(value))`` writes it (NumPy's ``str`` of a
    float64: the shortest decimal that reads back exactly), rows ended by CRLF as
    :class:`csv.writer` ends them."""
    with _writing(path), open(path, 'wb') as fh:
        np.savetxt(fh, rows, fmt='%s', delimiter=',', newline='\r\n', header=','.join(header), comments='')


def _write_npz(path: Path, header: Sequence[str], rows: np.ndarray) -> None:
    """NumPy's ``.npz`` archive of the columns of ``rows``, each named by its ``header``."""
    with _writing(path), open(path, 'wb') as fh:
        np.savez(fh, **{name: np.ascontiguousarray(rows[:, k]) for k, name in enumerate(header)})


def _read_trajectory(path: Path) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """The samples (K, 8) and, when the file has those columns, the twists and their rates."""
    try:
        with open(path, newline='') as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            missing = [c for c in TRAJECTORY_COLUMNS if c not in header]
            if missing:
                raise UsageError(f'{path}: missing columns {missing} (need {",".join(TRAJECTORY_COLUMNS)})')
            columns = list(TRAJECTORY_COLUMNS)
            for group in (VELOCITY_COLUMNS, ACCELERATION_COLUMNS):
                present = [c for c in group if c in header]
                if present and len(present) < len(group):
                    raise UsageError(f'{path}: has {",".join(present)} but not all of '
                                     f'{",".join(group)}')
                columns += present
            idx = [header.index(c) for c in columns]
            rows = []
            for n, row in enumerate(reader, start=2):
                if not row:
                    continue
                try:
                    rows.append([float(row[i]) for i in idx])
                except (ValueError, IndexError):
                    raise UsageError(f'{path}: line {n}: expected numbers in columns '
                                     f'{",".join(columns)}') from None
    except OSError as exc:
        raise UsageError(f'{path}: cannot read: {exc.strerror}') from None
    data = np.asarray(rows, dtype=float).reshape(-1, len(columns))
    if not np.all(np.isfinite(data)):
        raise UsageError(f'{path}: contains NaN or infinite values')
    twist = data[:, 8:14] if VELOCITY_COLUMNS[0] in columns else None
    twist_dot = data[:, -6:] if ACCELERATION_COLUMNS[0] in columns else None
    return data[:, :8], twist, twist_dot


def simulation_rows(res: SimulationResult) -> np.ndarray:
    """The simulate CSV's rows (columns SIMULATION_COLUMNS)."""
    return np.column_stack([res.t, res.position, res.quaternion_xyzw, res.lengths,
                            res.length_rates, res.forces, res.constraint_drift,
                            res.euler_norm_error, res.energy_balance, res.kinetic, res.potential,
                            res.actuator_work, res.step_flops, res.step_seconds])


def _simulate(g: RobotGeometry, args) -> list[str]:
    position, quat = _pose(g, args)
    if args.dt > args.duration:
        raise UsageError(f'--dt ({args.dt}) must not exceed --duration ({args.duration})')
    if args.npz is None and args.csv is None:
        raise UsageError('give the output: --npz and/or --csv')
    world = world_of(args)
    forces = args.forces
    if isinstance(forces, str):
        forces = MultibodyDynamics(g, args.method, support=world).holding_forces(position, quat)
    t0 = time.perf_counter()
    res = simulate(g, position, quat, forces, duration=args.duration, dt=args.dt,
                   method=args.method, output_every=args.output_every,
                   progress=_Progress(f'simulate ({args.method})'), reactions=args.reactions,
                   support=world)
    wall = time.perf_counter() - t0
    header, rows = SIMULATION_COLUMNS, simulation_rows(res)
    if args.reactions:
        header, rows = header + REACTION_COLUMNS, np.column_stack([rows, reaction_rows(res)])
    written = []
    for path, write in ((args.npz, _write_npz), (args.csv, _write_csv)):
        if path is not None:
            write(path, header, rows)
            written.append(str(path))
    if args.plot is not None:
        with _writing(args.plot):
            plot_simulation(res, args.plot,
                            f'{g.name}: constant forces, {args.method}, dt = {args.dt} s')
    lines = [f'robot: {g.name}   method: {args.method}   dt: {args.dt} s   duration: {args.duration} s',
             f'forces [N]: {format_vector(forces, 4)}',
             f'final position [m]: {format_vector(res.position[-1], 6)}',
             f'final quaternion: {format_vector(res.quaternion_xyzw[-1], 6)}',
             f'final lengths [m]: {format_vector(res.lengths[-1], 6)}',
             f'max drift ‖Φ‖: {np.max(res.constraint_drift):.3e}   max |pᵀp − 1|: '
             f'{np.max(res.euler_norm_error):.3e}   max |energy balance|: '
             f'{np.max(np.abs(res.energy_balance)):.3e} J',
             f'hybrid corrections: {res.corrections}' if args.method == 'hybrid' else '',
             f'wall time: {wall:.3f} s ({args.duration / wall:.1f}x real time)',
             f'wrote {len(res.t)} rows to {" and ".join(written)}' + (f', plot to {args.plot}' if args.plot else '')]
    out_of_stroke = (res.lengths < g.min_length) | (res.lengths > g.max_length)
    if np.any(out_of_stroke):
        first = res.t[np.argmax(np.any(out_of_stroke, axis=1))]
        print(f'{PROG}: warning: actuator lengths leave the stroke [{g.min_length}, '
              f'{g.max_length}] m at t = {first:.3f} s (the model does not stop them)',
              file=sys.stderr)
    return [line for line in lines if line]


def _statics(g: RobotGeometry, args) -> list[str]:
    from rrps_loads.loads import static_solution
    position, quat = _pose(g, args)
    sol = static_solution(g, (position, quat), support=world_of(args))
    return [statics_json(g, position, quat, sol)] if args.json else statics_lines(sol)


def _inverse(g: RobotGeometry, args) -> list[str]:
    from rrps_loads.inverse_dynamics import check_trajectory, inverse_dynamics
    data, twist, twist_dot = _read_trajectory(args.trajectory)
    try:
        check_trajectory(data[:, 0], data[:, 1:4], data[:, 4:8])
    except ValueError as exc:
        raise UsageError(f'{args.trajectory}: {exc}') from None
    forces = inverse_dynamics(g, data[:, 0], data[:, 1:4], data[:, 4:8], twist=twist,
                              twist_dot=twist_dot, support=world_of(args))
    _write_csv(args.csv, ['t'] + [f'F{i}' for i in range(1, 7)], np.column_stack([data[:, 0], forces]))
    return [f'wrote {len(data)} rows (t,F1..F6) to {args.csv}; '
            f'max |F| = {np.max(np.abs(forces)):.3f} N']


def _report(g: RobotGeometry, args) -> list[str]:
    try:
        args.out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f'{args.out_dir}: cannot create: {exc.strerror}') from None
    with _writing(args.out_dir / 'figure6_direct_kinematics.png') as out:
        lines6, _ = figure6(g, out)
    with _writing(args.out_dir / 'figure7_direct_dynamics.png') as out:
        lines7, _ = figure7(g, out, args.method, args.duration, args.dt,
                            progress=_Progress(f'figure 7 ({args.method})'))
    return lines6 + [''] + lines7


def run(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (docs/usage.md, 'Command-line tools')."""
    argv = list(sys.argv[1:] if argv is None else argv)

    def body() -> list[str]:
        args = build_parser().parse_args(join_negative_vectors(argv, _VECTOR_OPTIONS))
        g = load_robot_or_usage_error(args.robot)
        if args.command != 'report':
            g = with_loads(g, args)
        return COMMANDS[args.command](g, args)

    return run_command(PROG, body)


COMMANDS = {'simulate': _simulate, 'statics': _statics, 'inverse': _inverse, 'report': _report}


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point ``rrps-dynamics``."""
    sys.exit(run(argv))


if __name__ == '__main__':
    main()
