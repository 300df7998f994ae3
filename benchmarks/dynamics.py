#!/usr/bin/env python3
"""Benchmark of the multibody dynamics, the 91-coordinate direct kinematics and the inverse
dynamics.

    python benchmarks/dynamics.py [--robot pole_climber] [--duration 0.5] [--dt 0.001] [--repeats 5]

Target 13.3, the DAE at 1 ms steps at least as fast as MuJoCo on the same mechanism: the paper's
run (constant actuator forces from rest, ``--duration`` s, RK4 at ``--dt``) through ``simulate``
(hybrid, every step recorded) against MuJoCo's RK4 at the same step on the same 13 bodies,
generated here from the robot YAML (:func:`mjcf`): ring_b on a free joint, each leg a lower link
on a universal joint (two hinges) at ring_a and an upper link on a prismatic joint driven by a
motor, closed at ring_b by a spherical joint (an equality ``connect``); same masses, inertias,
gravity and actuator forces. MuJoCo runs as a Python loop of ``mj_step`` recording the pose, and
as ``rollout`` (its C loop); the ratio is taken against the faster. Runs alternate (best of
``--repeats`` each) and are timed in CPU time of this process (all single-threaded), as the 2
cores are shared: the wall times are printed too. Also printed: the largest joint drift ‖Φ^K‖
of the run (target <= 1e-10: the constraints stay exact) and MuJoCo's (soft constraints).
Target 13.5, inverse dynamics from positions within 1e-4 N of the exact forces on a smooth 1 kHz
trajectory, against the cubic-spline derivatives used before (same run).
Also: the three integrators' real-time ratio, one evaluation of eq. 19 structured against a dense
150 x 150 LAPACK solve and a whole dense RK4 run, and Newton DK on the 91 coordinates along
Figure 6's climb (structured, SuperLU, dense LAPACK; target <= 2 ms per solve).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import numpy as np
from scipy.interpolate import CubicSpline

from rrps_description.geometry import load_robot
from rrps_description.rotations import (
    matrix_to_quat_xyzw,
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    rotation_vector_to_quat_xyzw,
)
from rrps_description.world import STANDARD_GRAVITY
from rrps_kinematics import forward_kinematics, inverse_kinematics
from rrps_kinematics.backend import jit
from rrps_kinematics.inverse import universal_joint_frames
from rrps_kinematics.multibody import MultibodyModel
from rrps_loads.inverse_dynamics import inverse_dynamics
from rrps_loads.reduced import PlatformPose, generalized_forces
from rrps_loads.statics import solve_actuator_forces
from rrps_sim.dynamics import METHODS, MultibodyDynamics, simulate
from rrps_sim.dynamics.bundles import new_workspace, workspace
from rrps_sim.dynamics.constraints import leg_blocks
from rrps_sim.dynamics.kernels import accelerations
from rrps_sim.figures import REPORT_EXTRA_FORCES, climb_poses

MUJOCO_TARGET = 1.0          # rrps / MuJoCo time per step
DRIFT_TARGET = 1e-10         # ‖Φ^K‖ along the run
INVERSE_TARGET = 1e-4        # [N], position-only inverse dynamics against the exact forces


# --- MuJoCo baseline ---------------------------------------------------------------------------

def _numbers(values) -> str:
    return ' '.join(repr(float(x)) for x in np.ravel(values))


def mjcf(g, position, quaternion_xyzw, dt: float) -> str:
    """MJCF of the robot at a pose: the 13 bodies of the multibody model, same inertia."""
    ik = inverse_kinematics(g, position, quaternion_xyzw)
    links = ik.lower_link_rotations
    axes = universal_joint_frames(g)[:, :, 0]
    lo, up, rb = g.lower_link, g.upper_link, g.ring_b_body
    inertia = rb.inertia
    legs = []
    for k in range(6):
        R = links[k]
        x, y, z, w = matrix_to_quat_xyzw(R)
        legs.append(f'''
    <body name="lower{k}" pos="{_numbers(g.ring_a_anchors[k])}" quat="{_numbers([w, x, y, z])}">
      <inertial pos="0 0 {lo.com_from_joint!r}" mass="{lo.mass!r}"
                diaginertia="{_numbers([lo.inertia_transverse] * 2 + [lo.inertia_axial])}"/>
      <joint name="u{k}a" type="hinge" axis="{_numbers(R.T @ axes[k])}"/>
      <joint name="u{k}b" type="hinge" axis="0 1 0"/>
      <body name="upper{k}" pos="0 0 {float(ik.lengths[k])!r}">
        <inertial pos="0 0 {-up.com_from_joint!r}" mass="{up.mass!r}"
                  diaginertia="{_numbers([up.inertia_transverse] * 2 + [up.inertia_axial])}"/>
        <joint name="slide{k}" type="slide" axis="0 0 1"/>
      </body>
    </body>''')
    x, y, z, w = np.asarray(quaternion_xyzw, dtype=float)
    connect = '\n'.join(f'    <connect body1="upper{k}" body2="ring_b" anchor="0 0 0"/>'
                        for k in range(6))
    motors = '\n'.join(f'    <motor joint="slide{k}" gear="1"/>' for k in range(6))
    return f'''<mujoco model="{g.name}">
  <option timestep="{dt!r}" integrator="RK4" gravity="{_numbers(STANDARD_GRAVITY)}">
    <flag contact="disable"/>
  </option>
  <worldbody>
    <body name="ring_b" pos="{_numbers(position)}" quat="{_numbers([w, x, y, z])}">
      <freejoint/>
      <inertial pos="{_numbers(rb.com)}" mass="{float(rb.mass)!r}"
                fullinertia="{_numbers(inertia[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]])}"/>
    </body>{''.join(legs)}
  </worldbody>
  <equality>
{connect}
  </equality>
  <actuator>
{motors}
  </actuator>
</mujoco>'''


class MujocoRun:
    """The MuJoCo model of the robot at a pose and two ways to run it with constant forces."""

    def __init__(self, g, position, quaternion_xyzw, forces, dt):
        import mujoco
        from mujoco import rollout
        self.mujoco, self.rollout = mujoco, rollout
        self.model = mujoco.MjModel.from_xml_string(mjcf(g, position, quaternion_xyzw, dt))
        self.data = mujoco.MjData(self.model)
        self.forces = np.asarray(forces, dtype=float)
        self.com_b = np.asarray(g.ring_b_body.com, dtype=float)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        mujoco.mj_resetData(self.model, self.data)
        self.state0 = np.empty(mujoco.mj_stateSize(self.model, spec))
        mujoco.mj_getState(self.model, self.data, self.state0, spec)
        self.version = mujoco.__version__

    def loop(self, steps: int) -> np.ndarray:
        """mj_step in a Python loop, recording ring_b's pose (7) after every step."""
        m, d = self.model, self.data
        self.mujoco.mj_resetData(m, d)
        d.ctrl[:] = self.forces
        out = np.empty((steps, 7))
        for i in range(steps):
            self.mujoco.mj_step(m, d)
            out[i] = d.qpos[:7]
        return out

    def rolled(self, steps: int) -> np.ndarray:
        """rollout: the same steps in MuJoCo's C loop; its full states."""
        control = np.tile(self.forces, (1, steps, 1))
        state, _ = self.rollout.rollout(self.model, self.data, self.state0, control)
        return state[0]

    def violation(self) -> float:
        """The largest 'connect' residual [m] at the current state (soft constraints)."""
        self.mujoco.mj_forward(self.model, self.data)
        return float(np.max(np.abs(self.data.efc_pos[:self.data.ne])))


# --- dense baseline of eq. 19 --------------------------------------------------------------------

def dense_accelerations(dyn: MultibodyDynamics, q, v, forces, M):
    """Baseline: eq. 19 as one dense (78 + 72)^2 system, solved by LAPACK."""
    F = np.zeros(78)
    Phi = np.zeros((72, 78))
    gamma = np.zeros(72)
    B = np.empty((13, 18))
    g = np.empty(13)
    W = v.reshape(13, 6)[:, 3:]
    F.reshape(13, 6)[:, :3] = dyn.mass[:, None] * dyn.parameters.gravity
    F.reshape(13, 6)[:, 3:] = -np.cross(W, np.einsum('bij,bj->bi', dyn.inertia, W))
    for k in range(6):
        leg_blocks(q, v, k, dyn.parameters.joints, dyn.parameters.support, B, g)
        lo, up = 6 * (1 + 2 * k), 6 * (2 + 2 * k)
        cols = np.r_[0:6, lo:lo + 12]
        Phi[12 * k:12 * k + 12, cols] = B[:12]
        gamma[12 * k:12 * k + 12] = g[:12]
        F[lo:lo + 3] -= forces[k] * B[12, 12:15]
        F[up:up + 3] += forces[k] * B[12, 12:15]
    K = np.block([[M, Phi.T], [Phi, np.zeros((72, 72))]])
    return np.linalg.solve(K, np.concatenate([F, gamma]))[:78]


def mass_matrix(dyn: MultibodyDynamics) -> np.ndarray:
    M = np.zeros((78, 78))
    for b in range(13):
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = dyn.mass[b] * np.eye(3)
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = dyn.inertia[b]
    return M


def dense_rk4_run(dyn: MultibodyDynamics, forces, duration, dt) -> np.ndarray:
    """The baseline's RK4 (no stabilisation) on [q, v]; returns the final q."""
    M = mass_matrix(dyn)

    def f(q, v):
        P = q.reshape(13, 7)[:, 3:]
        Wb = v.reshape(13, 6)[:, 3:]
        e0, e = P[:, :1], P[:, 1:]
        pdot = 0.5 * np.concatenate([-np.sum(e * Wb, axis=1, keepdims=True),
                                     e0 * Wb + np.cross(e, Wb)], axis=1)
        dq = np.concatenate([v.reshape(13, 6)[:, :3], pdot], axis=1).ravel()
        return dq, dense_accelerations(dyn, q, v, forces, M)

    q, v = dyn.q, dyn.v
    for _ in range(int(round(duration / dt))):
        k1 = f(q, v)
        k2 = f(q + 0.5 * dt * k1[0], v + 0.5 * dt * k1[1])
        k3 = f(q + 0.5 * dt * k2[0], v + 0.5 * dt * k2[1])
        k4 = f(q + dt * k3[0], v + dt * k3[1])
        q = q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return q


@jit
def repeated_evaluations(q, v, forces, params, buffer, acc, n):
    """n evaluations of eq. 19 in one compiled loop (no call overhead in the timing)."""
    ws = workspace(buffer)
    for _ in range(n):
        accelerations(q, v, forces, 0.0, 0.0, params, ws, acc)


# --- inverse dynamics ----------------------------------------------------------------------------

def exact_trajectory(g, t, period=0.5, shift=(0.02, -0.01, 0.03), turn=(0.05, -0.03, 0.08)):
    """s(t) = (1 - cos(2π t / T)) / 2 along a shift and a turn about a fixed axis: the pose and
    its exact twist and twist rate (the quaternion turns about n, so ω = θ' n, ω̇ = θ'' n)."""
    w = 2 * np.pi / period
    s, ds, dds = 0.5 * (1 - np.cos(w * t)), 0.5 * w * np.sin(w * t), 0.5 * w**2 * np.cos(w * t)
    shift, turn = np.asarray(shift), np.asarray(turn)
    p = g.home_position + s[:, None] * shift
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(s[:, None] * turn), g.home_quaternion_xyzw)
    twist = np.concatenate([ds[:, None] * shift, ds[:, None] * turn], axis=1)
    twist_dot = np.concatenate([dds[:, None] * shift, dds[:, None] * turn], axis=1)
    return p, q, twist, twist_dot


def exact_forces(g, p, q, twist, twist_dot):
    pose = PlatformPose(g, p, q)
    return solve_actuator_forces(pose, generalized_forces(pose, twist, twist_dot))


def spline_forces(g, t, p, q):
    """The baseline: twists from C2 cubic splines of the samples (the method used before)."""
    pos, quat = CubicSpline(t, p, axis=0), CubicSpline(t, q, axis=0)
    dq, ddq = quat(t, 1), quat(t, 2)
    conj, norm = quat_conjugate_xyzw(q), np.sum(q * q, axis=1)[:, None]
    omega = 2.0 * quat_multiply_xyzw(dq, conj)[:, :3] / norm
    omega_dot = (2.0 * quat_multiply_xyzw(ddq, conj)[:, :3]
                 - 2.0 * np.sum(q * dq, axis=1)[:, None] * omega) / norm
    return exact_forces(g, p, q, np.concatenate([pos(t, 1), omega], axis=1),
                        np.concatenate([pos(t, 2), omega_dot], axis=1))


# --- the benchmark -------------------------------------------------------------------------------

def best_of(repeats, fn):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robot', default='pole_climber')
    parser.add_argument('--duration', type=float, default=0.5)
    parser.add_argument('--dt', type=float, default=0.001)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args(argv)
    g = load_robot(args.robot)
    position, quat = g.home_position, g.home_quaternion_xyzw
    dyn = MultibodyDynamics(g)
    forces = dyn.holding_forces(position, quat) + REPORT_EXTRA_FORCES
    steps = int(round(args.duration / args.dt))
    for method in METHODS:          # warm-up: numba compiles or loads its cache here
        simulate(g, position, quat, forces, duration=5 * args.dt, dt=args.dt, method=method)
    rows = []  # (name, value, unit, note)

    # Target 13.3: rrps against MuJoCo, alternating runs.
    mj = MujocoRun(g, position, quat, forces, args.dt)
    mj.loop(10)
    mj.rolled(10)
    cpu = {'rrps': np.inf, 'loop': np.inf, 'rollout': np.inf}
    wall = dict(cpu)
    for _ in range(args.repeats):
        for name, run in (('rrps', lambda: simulate(g, position, quat, forces,
                                                     duration=args.duration, dt=args.dt)),
                          ('loop', lambda: mj.loop(steps)), ('rollout', lambda: mj.rolled(steps))):
            c0, w0 = time.process_time(), time.perf_counter()
            out = run()
            wall[name] = min(wall[name], time.perf_counter() - w0)
            cpu[name] = min(cpu[name], time.process_time() - c0)
            if name == 'rrps':
                res = out
            elif name == 'loop':
                mj_pose = out
    us = {name: 1e6 * sec / steps for name, sec in cpu.items()}
    us_wall = {name: 1e6 * sec / steps for name, sec in wall.items()}
    mj_best = min(us['loop'], us['rollout'])
    ratio = us['rrps'] / mj_best
    drift = float(np.max(res.constraint_drift))
    mj_violation = mj.violation()
    agree = float(np.max(np.abs(mj_pose[-1, :3] - res.position[-1])))   # free joint = ring_b's frame
    moved = float(np.linalg.norm(res.position[-1] - res.position[0]))
    rows.append((f'DAE {args.duration} s at {1e3 * args.dt:g} ms, rrps hybrid (simulate)',
                 us['rrps'], 'us/step', f'CPU time (wall {us_wall["rrps"]:.1f}); max drift '
                 f'‖Φ^K‖ {drift:.1e}, ring_b moved {moved:.4f} m'))
    rows.append((f'same run, MuJoCo {mj.version} RK4, mj_step loop', us['loop'], 'us/step',
                 f'CPU time (wall {us_wall["loop"]:.1f}); soft constraints: violation '
                 f'{mj_violation:.1e} m; end differs by {agree:.1e} m'))
    rows.append((f'same run, MuJoCo {mj.version} RK4, rollout (C loop)', us['rollout'],
                 'us/step', f'CPU time (wall {us_wall["rollout"]:.1f})'))

    # The three integrators and eq. 19 against dense solves.
    ends, ratios = {}, {}
    for method in METHODS:
        sec, out = best_of(args.repeats, lambda: simulate(g, position, quat, forces,
                                                          duration=args.duration, dt=args.dt,
                                                          method=method))
        ratios[method] = args.duration / sec
        ends[method] = out.position[-1]
        rows.append((f'DAE {args.duration} s, {method} (simulate)', 1e3 * sec, 'ms',
                     f'{ratios[method]:.1f}x real time, {1e6 * sec / steps:.0f} us/step, '
                     f'max drift {np.max(out.constraint_drift):.1e}'))
    probe = MultibodyDynamics(g, 'baumgarte')
    probe.reset(position, quat)
    for _ in range(50):
        probe.step(forces, args.dt)
    q, v = probe.q, probe.v
    acc, buffer, n_eval = np.empty(78), new_workspace(), 2000
    repeated_evaluations(q, v, forces, probe.parameters, buffer, acc, 2)
    sec_s, _ = best_of(args.repeats, lambda: repeated_evaluations(q, v, forces, probe.parameters,
                                                                  buffer, acc, n_eval))
    M = mass_matrix(probe)
    sec_d, acc_d = best_of(args.repeats, lambda: [dense_accelerations(probe, q, v, forces, M)
                                                  for _ in range(n_eval // 10)])
    rows.append(('eq. 19 solve, structured (compiled loop)', 1e6 * sec_s / n_eval, 'us',
                 'per leg: 6 x 6 pivoted solve, effective mass; ring_b 6 x 6 Cholesky'))
    rows.append(('eq. 19 solve, dense 150x150 (baseline)', 1e6 * sec_d / (n_eval // 10), 'us',
                 f'{(sec_d / (n_eval // 10)) / (sec_s / n_eval):.0f}x slower; max |Δacc| '
                 f'{np.max(np.abs(acc_d[-1] - acc)):.1e}'))
    base = MultibodyDynamics(g, 'baumgarte', alpha=0.0, beta=0.0)
    base.reset(position, quat)
    sec_b, q_b = best_of(1, lambda: dense_rk4_run(base, forces, args.duration, args.dt))
    plain = simulate(g, position, quat, forces, duration=args.duration, dt=args.dt,
                     method='baumgarte', alpha=0.0, beta=0.0)
    diff = np.max(np.abs(base.model.pose_from_coordinates(q_b)[0] - plain.position[-1]))
    rows.append((f'DAE {args.duration} s, dense eq. 19 RK4 (baseline)', 1e3 * sec_b, 'ms',
                 f'{args.duration / sec_b:.2f}x real time; end differs by {diff:.1e} m'))

    # Target 13.5: inverse dynamics from positions at 1 kHz.
    t = np.arange(0.0, 0.5 + 5e-4, 1e-3)
    p, qt, twist, twist_dot = exact_trajectory(g, t)
    exact = exact_forces(g, p, qt, twist, twist_dot)
    sec_i, from_positions = best_of(args.repeats, lambda: inverse_dynamics(g, t, p, qt))
    error = float(np.max(np.abs(from_positions - exact)))
    spline_error = float(np.max(np.abs(spline_forces(g, t, p, qt) - exact)))
    with_rates = inverse_dynamics(g, t, p, qt, twist=twist, twist_dot=twist_dot)
    rows.append(('inverse dynamics from positions, 1 kHz, 0.5 s', error, 'N max err',
                 f'{1e3 * sec_i:.1f} ms for {len(t)} samples; |F| up to '
                 f'{np.max(np.abs(exact)):.1f} N'))
    rows.append(('same, cubic-spline derivatives (baseline)', spline_error, 'N max err', ''))
    rows.append(('same, velocities and accelerations given', float(np.max(np.abs(
        with_rates - exact))), 'N max err', ''))

    # Multibody DK along the climb.
    model = MultibodyModel(g)
    P, Q, _, _ = climb_poses()
    L = inverse_kinematics(g, P, Q).lengths
    seeds = [model.coordinates_from_pose(P[k], Q[k]) for k in range(len(P))]
    model.direct_kinematics(L[1], seeds[0])
    dk = {}
    for solver in ('structured', 'sparse', 'dense'):
        dk_times, its, errs = [], [], []
        for k in range(1, len(P)):
            sec, out = best_of(args.repeats, lambda: model.direct_kinematics(L[k], seeds[k - 1],
                                                                             solver=solver))
            dk_times.append(sec)
            its.append(out.iterations)
            errs.append(np.max(np.abs(out.position - P[k])))
        dk[solver] = np.array(dk_times)
        rows.append((f'multibody DK (91 coords), {solver}', 1e3 * np.median(dk_times), 'ms median',
                     f'max {1e3 * np.max(dk_times):.2f} ms, {np.mean(its):.1f} iterations, '
                     f'{out.flops / 1e3:.0f} kflop, max pose error {np.max(errs):.1e} m'))
    fk_times = [best_of(args.repeats, lambda: forward_kinematics(g, L[k], P[k - 1], Q[k - 1]))[0]
                for k in range(1, len(P))]
    rows.append(('pose-level FK (6 DOF), for scale', 1e3 * np.median(fk_times), 'ms median', ''))

    print(f'# rrps dynamics benchmark: {g.name}, {platform.processor() or platform.machine()}, '
          f'{os.cpu_count()} cores, Python {sys.version.split()[0]}')
    width = max(len(r[0]) for r in rows)
    for name, value, unit, note in rows:
        print(f'{name:{width}s}  {value:10.3g} {unit:10s}  {note}')
    verdicts = {
        'DAE vs MuJoCo': (ratio <= MUJOCO_TARGET and drift <= DRIFT_TARGET,
                          f'rrps {us["rrps"]:.1f} us/step, MuJoCo {mj_best:.1f} us/step (CPU, best '
                          f'of loop and rollout), ratio {ratio:.2f} (target <= {MUJOCO_TARGET}; '
                          f'wall: {us_wall["rrps"] / min(us_wall["loop"], us_wall["rollout"]):.2f}'
                          f'); drift {drift:.1e} (target <= {DRIFT_TARGET:.0e})'),
        'inverse dynamics': (error <= INVERSE_TARGET,
                             f'{error:.1e} N from positions (target <= {INVERSE_TARGET:.0e} N; '
                             f'cubic splines: {spline_error:.1e} N)'),
        'real time (hybrid)': (ratios['hybrid'] >= 5.0,
                               f'{ratios["hybrid"]:.1f}x real time (target >= 5x)'),
        'multibody DK': (np.max(dk['structured']) <= 2e-3,
                         f'worst solve {1e3 * np.max(dk["structured"]):.2f} ms (target <= 2 ms)'),
    }
    print()
    for name, (ok, text) in verdicts.items():
        print(f'{name}: {text}: {"MET" if ok else "MISSED"}')
    agree = max(np.max(np.abs(ends[m] - ends['hybrid'])) for m in METHODS)
    print(f'the three integrators end within {agree:.1e} m of each other')
    return 0 if all(ok for ok, _ in verdicts.values()) else 1


if __name__ == '__main__':
    sys.exit(main())
