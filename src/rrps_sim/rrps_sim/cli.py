"""``rrps-dynamics``: multibody dynamics, statics and the paper's cost figures from the shell.

    rrps-dynamics simulate --robot R [--position x,y,z] [--quaternion qx,qy,qz,qw]
        --forces f1,...,f6|hold --duration 0.5 --dt 0.001 --method {baumgarte,partitioning,hybrid}
        --csv out.csv [--plot out.png] [--output-every N]
    rrps-dynamics statics --robot R [--position x,y,z] [--quaternion qx,qy,qz,qw]
    rrps-dynamics inverse --robot R --trajectory traj.csv --csv forces.csv
    rrps-dynamics report  --robot R [--out-dir DIR] [--method M]     (Figures 6 and 7)

``--robot`` takes a shipped robot name (default ``pole_climber``) or a YAML path; the pose
defaults to the robot's home pose. Poses are a_T_b (ring_b in ring_a's frame), SI units, ROS
(x, y, z, w) quaternions; forces are positive when they push the rings apart. Exit status: 0
done, 1 the simulation hit a singular configuration, 2 bad arguments or input files (one error
line on stderr). Long runs show their progress on stderr.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path
from typing import Sequence

import numpy as np

from rrps_kinematics.cli_support import (
    OneLineParser,
    UsageError,
    count,
    join_negative_vectors,
    load_robot_or_usage_error,
    positive,
    vector,
)
from rrps_kinematics.geometry import RobotGeometry, shipped_robots
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.multibody import MultibodyModel
from rrps_kinematics.rotations import (
    matrix_to_quat_xyzw,
    quat_xyzw_to_matrix,
    rotation_angle_between,
    rotation_vector_to_matrix,
)

from .dynamics import METHODS, MultibodyDynamics, SimulationResult, simulate

PROG = 'rrps-dynamics'
_VECTOR_OPTIONS = ('--position', '--quaternion', '--forces')
SIMULATION_COLUMNS = (['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw']
                      + [f'L{i}' for i in range(1, 7)] + [f'Ldot{i}' for i in range(1, 7)]
                      + [f'F{i}' for i in range(1, 7)]
                      + ['constraint_drift', 'euler_norm_error', 'energy_balance', 'kinetic',
                         'potential', 'actuator_work', 'step_flops', 'step_seconds'])
TRAJECTORY_COLUMNS = ('t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw')

# Figure 6: the climb. Figure 7: the constant-force run (holding forces plus this pattern).
CLIMB_DISTANCE = 0.8          # [m] travelled by the moving ring, in total
CLIMB_PHASES = 11
CLIMB_SHORT_GAP = 0.36        # [m] ring separation along the trunk when contracted
CLIMB_CURVATURE = (0.0, 0.5)  # trunk curvature κ(s) = κ0 + κ1 s [1/m, 1/m^2]
REPORT_EXTRA_FORCES = np.array([1.2, 1.2, 1.0, 0.8, 0.8, 1.0])   # [N] over the holding forces


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
    p.add_argument('--csv', required=True, type=Path, help='output CSV, one row per output step')
    p.add_argument('--plot', type=Path, help='output PNG of the run')

    p = sub.add_parser('statics', help='actuator forces holding a pose at rest [N]')
    robot(p)
    pose(p)

    p = sub.add_parser('inverse', help='actuator forces along a pose trajectory')
    robot(p)
    p.add_argument('--trajectory', required=True, type=Path,
                   help='CSV with columns t,x,y,z,qx,qy,qz,qw (a header row)')
    p.add_argument('--csv', required=True, type=Path, help='output CSV: t,F1..F6')

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


def _write_csv(path: Path, header: Sequence[str], rows: np.ndarray) -> None:
    try:
        with open(path, 'w', newline='') as fh:
            w = csv.writer(fh)
            w.writerow(header)
            for row in rows:
                w.writerow([repr(float(x)) for x in row])
    except OSError as exc:
        raise UsageError(f'{path}: cannot write: {exc.strerror}') from None


def _read_trajectory(path: Path) -> np.ndarray:
    try:
        with open(path, newline='') as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            missing = [c for c in TRAJECTORY_COLUMNS if c not in header]
            if missing:
                raise UsageError(f'{path}: missing columns {missing} (need {",".join(TRAJECTORY_COLUMNS)})')
            idx = [header.index(c) for c in TRAJECTORY_COLUMNS]
            rows = []
            for n, row in enumerate(reader, start=2):
                if not row:
                    continue
                try:
                    rows.append([float(row[i]) for i in idx])
                except (ValueError, IndexError):
                    raise UsageError(f'{path}: line {n}: expected numbers in columns '
                                     f'{",".join(TRAJECTORY_COLUMNS)}') from None
    except OSError as exc:
        raise UsageError(f'{path}: cannot read: {exc.strerror}') from None
    data = np.asarray(rows, dtype=float).reshape(-1, 8)
    if not np.all(np.isfinite(data)):
        raise UsageError(f'{path}: contains NaN or infinite values')
    return data


def simulation_rows(res: SimulationResult) -> np.ndarray:
    """The simulate CSV's rows (columns SIMULATION_COLUMNS)."""
    return np.column_stack([res.t, res.position, res.quaternion_xyzw, res.lengths,
                            res.length_rates, res.forces, res.constraint_drift,
                            res.euler_norm_error, res.energy_balance, res.kinetic, res.potential,
                            res.actuator_work, res.step_flops, res.step_seconds])


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> None:
    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:
        raise UsageError(f'{path}: cannot write: {exc.strerror}') from None
    finally:
        _plt().close(fig)


def plot_simulation(res: SimulationResult, path: Path, title: str) -> None:
    """Pose, leg lengths, drift / Euler-norm error and the energy balance against time."""
    plt = _plt()
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5), constrained_layout=True)
    for i, name in enumerate('xyz'):
        ax[0, 0].plot(res.t, res.position[:, i] - res.position[0, i], label=f'Δ{name}')
    ax[0, 0].set(xlabel='t [s]', ylabel='ring_b displacement [m]', title='ring_b position')
    ax[0, 0].legend()
    for k in range(6):
        ax[0, 1].plot(res.t, res.lengths[:, k], label=f'L{k + 1}')
    ax[0, 1].set(xlabel='t [s]', ylabel='[m]', title='actuator lengths')
    ax[0, 1].legend(ncol=3, fontsize='small')
    ax[1, 0].semilogy(res.t, np.maximum(res.constraint_drift, 1e-18), label='‖Φ‖ (72 joints)')
    ax[1, 0].semilogy(res.t, np.maximum(res.euler_norm_error, 1e-18), label='max |pᵀp − 1|')
    ax[1, 0].set(xlabel='t [s]', title='constraint drift')
    ax[1, 0].legend()
    ax[1, 1].plot(res.t, res.energy_balance, label='T + V − W − E₀')
    ax[1, 1].set(xlabel='t [s]', ylabel='[J]', title='energy balance')
    ax[1, 1].legend()
    fig.suptitle(title)
    _save(fig, path)


# --- subcommands ----------------------------------------------------------------------------

def _simulate(g: RobotGeometry, args) -> list[str]:
    position, quat = _pose(g, args)
    if args.dt > args.duration:
        raise UsageError(f'--dt ({args.dt}) must not exceed --duration ({args.duration})')
    dyn = MultibodyDynamics(g, args.method)
    forces = dyn.holding_forces(position, quat) if isinstance(args.forces, str) else args.forces
    t0 = time.perf_counter()
    res = simulate(g, position, quat, forces, duration=args.duration, dt=args.dt,
                   method=args.method, output_every=args.output_every,
                   progress=_Progress(f'simulate ({args.method})'))
    wall = time.perf_counter() - t0
    _write_csv(args.csv, SIMULATION_COLUMNS, simulation_rows(res))
    if args.plot is not None:
        plot_simulation(res, args.plot, f'{g.name}: constant forces, {args.method}, dt = {args.dt} s')
    lines = [f'robot: {g.name}   method: {args.method}   dt: {args.dt} s   duration: {args.duration} s',
             f'forces [N]: {_fmt(forces, 4)}',
             f'final position [m]: {_fmt(res.position[-1], 6)}',
             f'final quaternion: {_fmt(res.quaternion_xyzw[-1], 6)}',
             f'final lengths [m]: {_fmt(res.lengths[-1], 6)}',
             f'max drift ‖Φ‖: {np.max(res.constraint_drift):.3e}   max |pᵀp − 1|: '
             f'{np.max(res.euler_norm_error):.3e}   max |energy balance|: '
             f'{np.max(np.abs(res.energy_balance)):.3e} J',
             f'hybrid corrections: {res.corrections}' if args.method == 'hybrid' else '',
             f'wall time: {wall:.3f} s ({args.duration / wall:.1f}x real time)',
             f'wrote {len(res.t)} rows to {args.csv}' + (f', plot to {args.plot}' if args.plot else '')]
    out_of_stroke = (res.lengths < g.min_length) | (res.lengths > g.max_length)
    if np.any(out_of_stroke):
        first = res.t[np.argmax(np.any(out_of_stroke, axis=1))]
        print(f'{PROG}: warning: actuator lengths leave the stroke [{g.min_length}, '
              f'{g.max_length}] m at t = {first:.3f} s (the model does not stop them)',
              file=sys.stderr)
    return [line for line in lines if line]


def _statics(g: RobotGeometry, args) -> list[str]:
    from .statics import holding_forces
    position, quat = _pose(g, args)
    forces = holding_forces(g, position, quat)
    return [f'leg_{k + 1}: {f:.6f} N' for k, f in enumerate(forces)]


def _inverse(g: RobotGeometry, args) -> list[str]:
    from .inverse_dynamics import inverse_dynamics
    data = _read_trajectory(args.trajectory)
    forces = inverse_dynamics(g, data[:, 0], data[:, 1:4], data[:, 4:8])
    _write_csv(args.csv, ['t'] + [f'F{i}' for i in range(1, 7)], np.column_stack([data[:, 0], forces]))
    return [f'wrote {len(data)} rows (t,F1..F6) to {args.csv}; '
            f'max |F| = {np.max(np.abs(forces)):.3f} N']


def climb_poses() -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Figure 6's climb: a_T_b for the start and after each of the 11 phases.

    The robot climbs a trunk whose axis is a planar curve of curvature κ(s) = κ0 + κ1 s. Each
    phase moves one ring 800/11 mm along the trunk (ring_b on odd phases, ring_a on even ones)
    while the other grips, so the moving ring travels 800 mm in total; a ring's frame has its z
    axis along the trunk. Returns positions (12, 3), quaternions (12, 4), the world positions of
    ring_a and ring_b (12, 2, 3) and which ring moved in each phase.
    """
    step = CLIMB_DISTANCE / CLIMB_PHASES
    s_fine = np.linspace(0.0, 3.0, 30001)
    k0, k1 = CLIMB_CURVATURE
    theta = k0 * s_fine + 0.5 * k1 * s_fine**2
    ds = s_fine[1] - s_fine[0]
    y = np.concatenate([[0.0], np.cumsum(0.5 * (np.sin(theta[1:]) + np.sin(theta[:-1])) * ds)])
    z = np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(theta[1:]) + np.cos(theta[:-1])) * ds)])

    def frame(s):
        th = np.interp(s, s_fine, theta)
        R = rotation_vector_to_matrix(np.array([-th, 0.0, 0.0]))
        return np.array([0.0, np.interp(s, s_fine, y), np.interp(s, s_fine, z)]), R

    s_a, s_b = 0.0, CLIMB_SHORT_GAP
    positions, quats, world, moved = [], [], [], []
    for phase in range(CLIMB_PHASES + 1):
        if phase > 0:
            if phase % 2 == 1:
                s_b += step
                moved.append('ring_b')
            else:
                s_a += step
                moved.append('ring_a')
        pa, Ra = frame(s_a)
        pb, Rb = frame(s_b)
        positions.append(Ra.T @ (pb - pa))
        quats.append(matrix_to_quat_xyzw(Ra.T @ Rb))
        world.append([pa, pb])
    return np.asarray(positions), np.asarray(quats), np.asarray(world), moved


def figure6(g: RobotGeometry, out: Path, seeds: int = 8, repeats: int = 5
            ) -> tuple[list[str], dict]:
    """Multibody DK along the climb: per phase iterations, flops, time and solutions found.

    Each phase's DK is seeded with the previous phase's solution; its time is the best of
    ``repeats`` identical solves (the machine is shared). Solutions: distinct poses reached from
    the previous solution and ``seeds`` more seeds scattered around it (±30 mm, ±0.08 rad)."""
    model = MultibodyModel(g)
    positions, quats, world, moved = climb_poses()
    q = model.coordinates_from_pose(positions[0], quats[0])
    model.direct_kinematics(inverse_kinematics(g, positions[0], quats[0]).lengths, q)  # warm-up
    rng = np.random.default_rng(6)
    rows = []
    for phase in range(1, len(positions)):
        L = inverse_kinematics(g, positions[phase], quats[phase]).lengths
        dk = model.direct_kinematics(L, q)
        best = min([dk.seconds] + [model.direct_kinematics(L, q).seconds for _ in range(repeats - 1)])
        pos_err = float(np.max(np.abs(dk.position - positions[phase])))
        ang_err = float(rotation_angle_between(quat_xyzw_to_matrix(dk.quaternion_xyzw),
                                               quat_xyzw_to_matrix(quats[phase])))
        # Distinct solutions reached from seeds scattered around the previous pose.
        prev_p, prev_q = model.pose_from_coordinates(q)
        found = [dk.position]
        for _ in range(seeds):
            Rs = rotation_vector_to_matrix(rng.uniform(-0.08, 0.08, 3)) @ quat_xyzw_to_matrix(prev_q)
            seed_q = model.coordinates_from_pose(prev_p + rng.uniform(-0.03, 0.03, 3),
                                                 matrix_to_quat_xyzw(Rs))
            other = model.direct_kinematics(L, seed_q)
            if other.converged and not any(np.max(np.abs(other.position - f)) < 1e-6 for f in found):
                found.append(other.position)
        rows.append(dict(phase=phase, moved=moved[phase - 1], iterations=dk.iterations,
                         flops=dk.flops, ms=1e3 * best, converged=dk.converged,
                         pos_err=pos_err, ang_err=ang_err, solutions=len(found)))
        q = dk.q
    plt = _plt()
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5), constrained_layout=True)
    ph = [r['phase'] for r in rows]
    ax[0, 0].bar(ph, [r['flops'] / 1e3 for r in rows], color='tab:blue')
    ax[0, 0].set(xlabel='phase', ylabel='kflop', title='operations per DK solve (flop model)')
    ax[0, 1].bar(ph, [r['iterations'] for r in rows], color='tab:orange')
    ax[0, 1].set(xlabel='phase', ylabel='Newton iterations', title='iterations (eqs. 11-12)')
    ax[1, 0].bar(ph, [r['ms'] for r in rows], color='tab:green')
    ax[1, 0].set(xlabel='phase', ylabel='[ms]', title='wall time per DK solve (best of 5)')
    for i, (name, marker) in enumerate((('ring_a', 's'), ('ring_b', 'o'))):
        ax[1, 1].plot(np.arange(len(world)), 1e3 * world[:, i, 2], marker=marker, label=name)
    ax[1, 1].set(xlabel='phase', ylabel='world height z [mm]',
                 title=f'the climb: {CLIMB_DISTANCE * 1e3:.0f} mm in {CLIMB_PHASES} phases')
    ax[1, 1].legend()
    fig.suptitle(f'Figure 6: multibody direct kinematics (91 coordinates), {g.name}')
    _save(fig, out)
    lines = [f'Figure 6: multibody DK along an {CLIMB_DISTANCE * 1e3:.0f} mm climb in '
             f'{CLIMB_PHASES} phases ({g.name}) -> {out}',
             'phase  moved   iter   kflop   time[ms]  conv  pose err [m]  angle err [rad]  solutions']
    for r in rows:
        lines.append(f"{r['phase']:5d}  {r['moved']:6s}  {r['iterations']:4d}  {r['flops'] / 1e3:7.1f}"
                     f"  {r['ms']:8.3f}  {'yes' if r['converged'] else 'NO':4s}  {r['pos_err']:12.2e}"
                     f"  {r['ang_err']:15.2e}  {r['solutions']:9d}")
    return lines, {'rows': rows}


def _robot_segments(g: RobotGeometry, position, quat):
    R = quat_xyzw_to_matrix(quat)
    b = position + g.ring_b_anchors @ R.T
    return g.ring_a_anchors, b


def figure7(g: RobotGeometry, out: Path, method: str, duration: float, dt: float
            ) -> tuple[list[str], dict]:
    """The constant-force run from the home pose: motion and cost per step."""
    position, quat = g.home_position, g.home_quaternion_xyzw
    dyn = MultibodyDynamics(g, method)
    forces = dyn.holding_forces(position, quat) + REPORT_EXTRA_FORCES
    simulate(g, position, quat, forces, duration=min(duration, 5 * dt), dt=dt, method=method)
    t0 = time.perf_counter()
    res = simulate(g, position, quat, forces, duration=duration, dt=dt, method=method,
                   progress=_Progress(f'figure 7 ({method})'))
    wall = time.perf_counter() - t0
    plt = _plt()
    fig = plt.figure(figsize=(12, 8), constrained_layout=True)
    ax3 = fig.add_subplot(2, 2, 1, projection='3d')
    picks = [0, len(res.t) // 2, len(res.t) - 1]
    for idx, color in zip(picks, ('tab:blue', 'tab:orange', 'tab:red')):
        a, b = _robot_segments(g, res.position[idx], res.quaternion_xyzw[idx])
        for k in range(6):
            ax3.plot(*zip(a[k], b[k]), color=color, lw=1.5)
        ring = np.vstack([b, b[:1]])
        ax3.plot(ring[:, 0], ring[:, 1], ring[:, 2], color=color, lw=2,
                 label=f't = {res.t[idx]:.2f} s')
    ring_a = np.vstack([g.ring_a_anchors, g.ring_a_anchors[:1]])
    ax3.plot(ring_a[:, 0], ring_a[:, 1], ring_a[:, 2], color='k', lw=2)
    ax3.set(xlabel='x [m]', ylabel='y [m]', zlabel='z [m]', title='the robot (ring_a fixed)')
    ax3.legend(fontsize='small')
    ax = fig.add_subplot(2, 2, 2)
    for i, name in enumerate('xyz'):
        ax.plot(res.t, 1e3 * (res.position[:, i] - res.position[0, i]), label=f'Δ{name}')
    ax.set(xlabel='t [s]', ylabel='[mm]', title='ring_b displacement')
    ax.legend()
    ax = fig.add_subplot(2, 2, 3)
    for k in range(6):
        ax.plot(res.t, res.lengths[:, k], label=f'L{k + 1}')
    ax.set(xlabel='t [s]', ylabel='[m]', title='actuator lengths')
    ax.legend(ncol=3, fontsize='small')
    ax = fig.add_subplot(2, 2, 4)
    ax.plot(res.t[1:], res.step_flops[1:] / 1e3, color='tab:blue', label='kflop per step (model)')
    ax.set(xlabel='t [s]', ylabel='kflop per step', title='cost per integration step')
    ax2 = ax.twinx()
    ax2.plot(res.t[1:], 1e6 * res.step_seconds[1:], color='tab:green', lw=0.8,
             label='µs per step (wall)')
    ax2.set(ylabel='µs per step')
    ax.legend(loc='upper left')
    ax2.legend(loc='upper right')
    fig.suptitle(f'Figure 7: direct dynamics, constant actuator forces for {duration} s, '
                 f'{method}, dt = {dt} s, {g.name}')
    _save(fig, out)
    n = len(res.t) - 1
    lines = [f'Figure 7: constant forces {_fmt(forces, 2)} N for {duration} s ({method}) -> {out}',
             f'  ring_b displacement at the end [mm]: {_fmt(1e3 * (res.position[-1] - res.position[0]), 3)}',
             f'  steps: {n}   kflop per step: mean {np.mean(res.step_flops[1:]) / 1e3:.1f}, '
             f'total {np.sum(res.step_flops) / 1e6:.2f} Mflop',
             f'  time per step: mean {1e6 * np.mean(res.step_seconds[1:]):.1f} µs, '
             f'max {1e6 * np.max(res.step_seconds[1:]):.1f} µs; run {wall:.3f} s = '
             f'{duration / wall:.1f}x real time',
             f'  max drift ‖Φ‖ {np.max(res.constraint_drift):.2e}, max |pᵀp − 1| '
             f'{np.max(res.euler_norm_error):.2e}, max |energy balance| '
             f'{np.max(np.abs(res.energy_balance)):.2e} J, hybrid corrections {res.corrections}']
    return lines, {'result': res}


def _report(g: RobotGeometry, args) -> list[str]:
    try:
        args.out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f'{args.out_dir}: cannot create: {exc.strerror}') from None
    lines6, _ = figure6(g, args.out_dir / 'figure6_direct_kinematics.png')
    lines7, _ = figure7(g, args.out_dir / 'figure7_direct_dynamics.png', args.method,
                        args.duration, args.dt)
    return lines6 + [''] + lines7


def _fmt(v, digits: int) -> str:
    return '[' + ', '.join(f'{x:.{digits}f}' for x in np.asarray(v, dtype=float)) + ']'


def run(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args = parser.parse_args(join_negative_vectors(argv, _VECTOR_OPTIONS))
        g = load_robot_or_usage_error(args.robot)
        handler = {'simulate': _simulate, 'statics': _statics, 'inverse': _inverse,
                   'report': _report}[args.command]
        lines = handler(g, args)
    except (UsageError, ValueError) as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return 2
    except RuntimeError as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return 1
    print('\n'.join(lines))
    return 0


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point ``rrps-dynamics``."""
    sys.exit(run(argv))


if __name__ == '__main__':
    main()
