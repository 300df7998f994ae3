"""The paper's Figures 6 (direct kinematics, eqs. 11-12, along an 800 mm climb in 11 phases) and 7
(direct dynamics, eqs. 19-20, and its cost per step) reproduced (``rrps-dynamics report``); a run's plot."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import (
    matrix_to_quat_xyzw,
    quat_xyzw_to_matrix,
    rotation_angle_between,
    rotation_vector_to_matrix,
)
from rrps_kinematics.cli_support import format_vector
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.multibody import MultibodyModel
from rrps_sim.dynamics import MultibodyDynamics, SimulationResult, simulate

__all__ = ['CLIMB_CURVATURE', 'CLIMB_DISTANCE', 'CLIMB_PHASES', 'CLIMB_SHORT_GAP',
           'REPORT_EXTRA_FORCES', 'climb_poses', 'figure6', 'figure7',
           'plot_simulation']

# Figure 6: the climb. Figure 7: the constant-force run (holding forces plus this pattern).
CLIMB_DISTANCE = 0.8          # [m] travelled by the moving ring, in total
CLIMB_PHASES = 11
CLIMB_SHORT_GAP = 0.36        # [m] ring separation along the trunk when contracted
CLIMB_CURVATURE = (0.0, 0.5)  # trunk curvature κ(s) = κ0 + κ1 s [1/m, 1/m^2]
REPORT_EXTRA_FORCES = np.array([1.2, 1.2, 1.0, 0.8, 0.8, 1.0])   # [N] over the holding forces


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> None:
    """Write the figure as a PNG (OSError if the path cannot be written) and release it."""
    try:
        fig.savefig(path, dpi=110)
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


def climb_poses() -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Figure 6's climb: a_T_b at the start and after each of the 11 phases, each moving one ring
    800/11 mm along a trunk of curvature κ(s) = κ0 + κ1 s (ring_b on odd phases). Returns positions
    (12, 3), quaternions (12, 4), both rings' world positions (12, 2, 3) and the ring moved per phase."""
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


def figure7(g: RobotGeometry, out: Path, method: str, duration: float, dt: float,
            progress: Callable[[float], None] | None = None) -> tuple[list[str], dict]:
    """The constant-force run from the home pose: motion and cost per step.

    ``progress(fraction)`` follows the timed run (see :func:`rrps_sim.dynamics.simulate`)."""
    position, quat = g.home_position, g.home_quaternion_xyzw
    dyn = MultibodyDynamics(g, method)
    forces = dyn.holding_forces(position, quat) + REPORT_EXTRA_FORCES
    simulate(g, position, quat, forces, duration=min(duration, 5 * dt), dt=dt, method=method)
    t0 = time.perf_counter()
    res = simulate(g, position, quat, forces, duration=duration, dt=dt, method=method,
                   progress=progress)
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
    lines = [f'Figure 7: constant forces {format_vector(forces, 2)} N for {duration} s ({method}) -> {out}',
             f'  ring_b displacement at the end [mm]: {format_vector(1e3 * (res.position[-1] - res.position[0]), 3)}',
             f'  steps: {n}   kflop per step: mean {np.mean(res.step_flops[1:]) / 1e3:.1f}, '
             f'total {np.sum(res.step_flops) / 1e6:.2f} Mflop',
             f'  time per step: mean {1e6 * np.mean(res.step_seconds[1:]):.1f} µs, '
             f'max {1e6 * np.max(res.step_seconds[1:]):.1f} µs; run {wall:.3f} s = '
             f'{duration / wall:.1f}x real time',
             f'  max drift ‖Φ‖ {np.max(res.constraint_drift):.2e}, max |pᵀp − 1| '
             f'{np.max(res.euler_norm_error):.2e}, max |energy balance| '
             f'{np.max(np.abs(res.energy_balance)):.2e} J, hybrid corrections {res.corrections}']
    return lines, {'result': res}
