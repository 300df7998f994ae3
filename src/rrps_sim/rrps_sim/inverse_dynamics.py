"""Inverse dynamics of an RRPS platform: actuator forces along a prescribed ring_b trajectory.

The trajectory is given as samples (t_k, r_k, q_k). Velocities and accelerations come from
C2 cubic splines through the samples (scipy ``CubicSpline``, not-a-knot ends), one for the
position and one for the quaternion's four components (signs made continuous first). For the
spline quaternion q(t), not exactly unit between samples, the angular velocity in ring_a's
frame is omega = 2 vec(q_dot ⊗ q*) / |q|^2 and its rate
omega_dot = (2 vec(q_ddot ⊗ q*) - 2 (q . q_dot) omega) / |q|^2: exact derivatives of one curve.
The forces then solve eq. 19 written in ring_b's twist (:mod:`rrps_sim.reduced`):
J^T f = M t_dot + Q0(x, t), at every sample.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from rrps_kinematics.geometry import RobotGeometry
from rrps_kinematics.rotations import quat_conjugate_xyzw, quat_multiply_xyzw

from .reduced import PlatformPose, generalized_forces
from .statics import solve_actuator_forces

__all__ = ['check_trajectory', 'trajectory_twists', 'inverse_dynamics']

MIN_SAMPLES = 4


def check_trajectory(t, positions, quaternions_xyzw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples as float arrays, quaternions unit and sign-continuous; ValueError if they are
    not a trajectory (shapes, fewer than MIN_SAMPLES, NaN/inf, t not increasing, zero quaternion)."""
    t = np.asarray(t, dtype=float)
    p = np.asarray(positions, dtype=float)
    q = np.asarray(quaternions_xyzw, dtype=float)
    if t.ndim != 1 or t.shape[0] < MIN_SAMPLES:
        raise ValueError(
            f't must be a 1-D array of at least {MIN_SAMPLES} samples, got shape {t.shape}')
    k = t.shape[0]
    if p.shape != (k, 3):
        raise ValueError(f'positions must have shape ({k}, 3), got {p.shape}')
    if q.shape != (k, 4):
        raise ValueError(f'quaternions_xyzw must have shape ({k}, 4), got {q.shape}')
    for name, arr in (('t', t), ('positions', p), ('quaternions_xyzw', q)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f'{name} contains NaN or infinite values')
    if np.any(np.diff(t) <= 0.0):
        raise ValueError('t must be strictly increasing')
    norm = np.linalg.norm(q, axis=1)
    if np.any(norm < 1e-12):
        raise ValueError('quaternions_xyzw contains a zero quaternion')
    q = q / norm[:, None]
    # q and -q are one rotation: pick the signs that make the samples a continuous curve.
    flips = np.concatenate([[False], np.sum(q[1:] * q[:-1], axis=1) < 0.0])
    q = q * np.where(np.logical_xor.accumulate(flips), -1.0, 1.0)[:, None]
    return t, p, q


def _spline_twists(t: np.ndarray, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pos = CubicSpline(t, p, axis=0)
    quat = CubicSpline(t, q, axis=0)
    q_dot, q_ddot = quat(t, 1), quat(t, 2)
    conj = quat_conjugate_xyzw(q)
    norm_sq = np.sum(q * q, axis=1)[:, None]
    omega = 2.0 * quat_multiply_xyzw(q_dot, conj)[:, :3] / norm_sq
    omega_dot = (2.0 * quat_multiply_xyzw(q_ddot, conj)[:, :3]
                 - 2.0 * np.sum(q * q_dot, axis=1)[:, None] * omega) / norm_sq
    twist = np.concatenate([pos(t, 1), omega], axis=1)
    twist_dot = np.concatenate([pos(t, 2), omega_dot], axis=1)
    return twist, twist_dot


def trajectory_twists(t, positions, quaternions_xyzw) -> tuple[np.ndarray, np.ndarray]:
    """Twists (K, 6) and their rates (K, 6) of ring_b at the samples, from the splines above."""
    return _spline_twists(*check_trajectory(t, positions, quaternions_xyzw))


def inverse_dynamics(geometry: RobotGeometry, t, positions, quaternions_xyzw) -> np.ndarray:
    """Actuator forces (K, 6) [N] (+ = pushing the rings apart) along a sampled ring_b trajectory.

    ``t`` (K,) strictly increasing [s], ``positions`` (K, 3) [m], ``quaternions_xyzw`` (K, 4)
    give a_T_b at each sample (K >= 4). Includes the inertia and weight of ring_b and of the
    twelve leg links. Raises ValueError for invalid input or a singular pose on the way.
    """
    t, p, q = check_trajectory(t, positions, quaternions_xyzw)
    twist, twist_dot = _spline_twists(t, p, q)
    pose = PlatformPose(geometry, p, q)
    return solve_actuator_forces(pose, generalized_forces(pose, twist, twist_dot))
