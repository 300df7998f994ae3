"""Inverse dynamics of an RRPS platform: actuator forces along a prescribed ring_b trajectory.

Samples (t_k, r_k, q_k), with ring_b's twist and its rate when known (ring_a's frame), else
differentiated by 7-point finite differences (:func:`sample_derivatives`); the forces solve eq. 19
in ring_b's twist, J^T f = M ṫ + Q0 (:mod:`rrps_loads.reduced`), on either supporting ring.
"""

from __future__ import annotations

from math import factorial

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_conjugate_xyzw, quat_multiply_xyzw
from rrps_loads.reduced import PlatformPose, generalized_forces
from rrps_loads.statics import solve_actuator_forces
from rrps_loads.support import support_of

__all__ = ['STENCIL', 'check_trajectory', 'inverse_dynamics', 'sample_derivatives',
           'trajectory_twists']

MIN_SAMPLES = 4
#: Samples per finite-difference stencil: exact for polynomials of degree < STENCIL, errors
#: O(h^6) for velocities and O(h^5) (O(h^6) centred on a uniform grid) for accelerations.
STENCIL = 7


def check_trajectory(t, positions, quaternions_xyzw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples as float arrays, quaternions unit and sign-continuous. ValueError if they are
    not a trajectory: shapes, fewer than MIN_SAMPLES, NaN/inf, t not increasing, a zero
    quaternion."""
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


def sample_derivatives(t, y, stencil: int = STENCIL) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivatives (K, D) of samples y (K, D) at their times t (K,).

    Finite differences on ``stencil`` consecutive samples around each one (centred where
    possible, shifted at the ends): the weights w solve Σ_j w_j (t_j - t_i)^p / p! = δ_pd for
    p < stencil, so the result is exact for polynomials of degree < stencil, on any spacing.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    k = t.shape[0]
    m = min(stencil, k)
    start = np.clip(np.arange(k) - m // 2, 0, k - m)
    window = start[:, None] + np.arange(m)
    h = (t[window[:, -1]] - t[window[:, 0]]) / (m - 1)      # the stencil's mean spacing
    x = (t[window] - t[:, None]) / h[:, None]               # offsets of order 1
    powers = np.arange(m)
    V = x[:, None, :] ** powers[None, :, None] / np.array([factorial(p) for p in powers])[:, None]
    unit = np.zeros((m, 2))
    unit[1, 0] = unit[2, 1] = 1.0
    w = np.linalg.solve(V, np.broadcast_to(unit, (k, m, 2)))
    dy = y[window] - y[:, None, :]                            # Σ w = 0: relative to the sample
    first = np.einsum('km,kmd->kd', w[:, :, 0], dy) / h[:, None]
    second = np.einsum('km,kmd->kd', w[:, :, 1], dy) / h[:, None] ** 2
    return first, second


def _twist_parts(t, p, q):
    """Twists (K, 6) and their rates (K, 6) differentiated from the samples."""
    dp, ddp = sample_derivatives(t, p)
    dq, ddq = sample_derivatives(t, q)
    conj = quat_conjugate_xyzw(q)
    norm_sq = np.sum(q * q, axis=1)[:, None]
    omega = 2.0 * quat_multiply_xyzw(dq, conj)[:, :3] / norm_sq
    omega_dot = (2.0 * quat_multiply_xyzw(ddq, conj)[:, :3]
                 - 2.0 * np.sum(q * dq, axis=1)[:, None] * omega) / norm_sq
    return np.concatenate([dp, omega], axis=1), np.concatenate([ddp, omega_dot], axis=1)


def trajectory_twists(t, positions, quaternions_xyzw) -> tuple[np.ndarray, np.ndarray]:
    """Twists (K, 6) and their rates (K, 6) of ring_b at the samples, by finite differences."""
    return _twist_parts(*check_trajectory(t, positions, quaternions_xyzw))


def _given(name: str, value, k: int) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != (k, 6):
        raise ValueError(f'{name} must have shape ({k}, 6), got {a.shape}')
    if not np.all(np.isfinite(a)):
        raise ValueError(f'{name} contains NaN or infinite values')
    return a


def inverse_dynamics(geometry: RobotGeometry, t, positions, quaternions_xyzw, *, twist=None,
                     twist_dot=None, support='ring_a', world_q_support=None, gravity=None) -> np.ndarray:
    """Actuator forces (K, 6) [N] (+ = pushing the rings apart) along a sampled ring_b trajectory.

    ``t`` (K,) increasing [s], a_T_b as ``positions`` (K, 3) [m] and ``quaternions_xyzw`` (K >= 4);
    ``twist``/``twist_dot`` (K, 6) in ring_a's frame, differentiated when absent; ``support`` as
    :func:`rrps_loads.support.support_of`. Raises ValueError, SingularPoseError at a singular pose.
    """
    world = support_of(support, world_q_support, gravity)
    t, p, q = check_trajectory(t, positions, quaternions_xyzw)
    k = t.shape[0]
    if twist is not None:
        twist = _given('twist', twist, k)
    if twist_dot is not None:
        twist_dot = _given('twist_dot', twist_dot, k)
    if twist is None:
        twist, rate = _twist_parts(t, p, q)
        twist_dot = rate if twist_dot is None else twist_dot
    elif twist_dot is None:
        twist_dot = sample_derivatives(t, twist)[0]
    pose = PlatformPose(geometry, p, q, world)
    return solve_actuator_forces(pose, generalized_forces(pose, twist, twist_dot))
