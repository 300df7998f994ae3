"""The preview of a climbing motion (rrps_sim.preview) against independent computations: the
reduced 6-DOF inverse dynamics along the same trajectory (the peak actuator force, on either ring,
in a turned world) and a momentum balance written here (the structure's force on the supporting
ring); a motion that breaks a limit is reported with the limit, the leg or ring and where."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_interfaces.climb import PreviewLimit
from rrps_kinematics.inverse import inverse_kinematics
from rrps_loads.inverse_dynamics import inverse_dynamics
from rrps_sim.preview import Drives, PreviewMotion, preview_step

GEOM = load_robot('pole_climber')
WALL = rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0]))   # the ring's axis horizontal
DT = 0.001
T = 0.4          # a fast motion: inertia matters [s]
SETTLE = 0.1
#: the driver's drives without its speed limit and without its jerk-limited setpoints (the motion
#: is faster than the robot's limits: the commands reach the drives as they are)
FAST = Drives(max_speed=math.inf, jerk_limited=False)


def _trajectory(t):
    """ring_b from home, rising 50 mm, sliding 20 mm and tilting 0.1 rad, rest to rest."""
    s = np.where(t < T, 0.5 * (1.0 - np.cos(np.pi * np.clip(t, 0.0, T) / T)), 1.0)
    positions = GEOM.home_position + s[:, None] * np.array([0.02, 0.0, 0.05])
    quaternions = rotation_vector_to_quat_xyzw(s[:, None] * np.array([0.1, 0.0, 0.0]))
    return positions, quaternions


def _motion(support):
    t = np.arange(0.0, T + DT / 2, DT)
    positions, quaternions = _trajectory(t)
    return PreviewMotion('test move', support, WALL, positions, quaternions, DT)


def _delayed_samples(tau):
    """The trajectory the drives follow: the commands lagged by the reference's time constant
    (a first-order lag of a smooth signal is the signal delayed by tau, to first order)."""
    t = np.arange(0.0, T + SETTLE, 0.002)
    return (t,) + _trajectory(t - tau)


@pytest.mark.parametrize('support', ['ring_a', 'ring_b'])
def test_the_peak_force_is_that_of_the_reduced_inverse_dynamics_along_the_motion(support):
    drives = FAST
    result = preview_step(GEOM, [_motion(support)], drives=drives, dt=DT, settle=SETTLE)
    t, positions, quaternions = _delayed_samples(drives.time_constant)
    forces = inverse_dynamics(GEOM, t, positions, quaternions, support=support, world_q_support=WALL)
    peak = np.abs(forces).max()
    leg = int(np.argmax(np.abs(forces).max(axis=0))) + 1
    statics = np.abs(inverse_dynamics(GEOM, t, positions, quaternions, twist=np.zeros((len(t), 6)),
                                      twist_dot=np.zeros((len(t), 6)), support=support,
                                      world_q_support=WALL)).max()
    assert result.peak_force == pytest.approx(peak, rel=0.01)
    # the motion's inertia shows: the preview is nearer the dynamics than the statics
    assert abs(result.peak_force - peak) < 0.5 * abs(result.peak_force - statics)
    assert result.peak_leg == leg
    assert result.accepted and result.limit is None
    assert result.simulated == pytest.approx(T + SETTLE, abs=2 * DT)


def _body_coms(positions, quaternions):
    """Masses (B,) and com positions (K, B, 3) in ring_a's frame of ring_b and the 12 leg links,
    from the leg geometry (eq. 1): lower link a_i + c_l u_i, upper link B_i - c_u u_i."""
    ik = inverse_kinematics(GEOM, positions, quaternions)
    lo, up = GEOM.lower_link, GEOM.upper_link
    R = quat_xyzw_to_matrix(quaternions)
    ring_b = positions + np.einsum('kij,j->ki', R, GEOM.ring_b_body.com)
    spherical = GEOM.ring_a_anchors + ik.leg_vectors
    lower = GEOM.ring_a_anchors + lo.com_from_joint * ik.unit_vectors
    upper = spherical - up.com_from_joint * ik.unit_vectors
    masses = np.concatenate([[GEOM.ring_b_body.mass], np.full(6, lo.mass), np.full(6, up.mass)])
    return masses, np.concatenate([ring_b[:, None], lower, upper], axis=1), R


@pytest.mark.parametrize('support', ['ring_a', 'ring_b'])
def test_the_peak_reaction_force_is_the_momentum_balance_of_the_moving_bodies(support):
    """F (structure on the supporting ring) = Σ m a - Σ m g over every body, in an inertial frame:
    the supporting ring's, where the ring at rest contributes only its weight."""
    drives = FAST
    result = preview_step(GEOM, [_motion(support)], drives=drives, dt=DT, settle=SETTLE)
    h = 0.001
    t = np.arange(0.0, T + SETTLE, h)
    positions, quaternions = _trajectory(t - drives.time_constant)
    masses, coms, R = _body_coms(positions, quaternions)
    g_world = np.array([0.0, 0.0, -9.81])
    g_support = quat_xyzw_to_matrix(WALL).T @ g_world
    if support == 'ring_a':
        moving = coms
        rest = GEOM.ring_a_body.mass
    else:   # everything seen from ring_b: x_b = R^T (x_a - p)
        moving = np.einsum('kji,kbj->kbi', R, coms - positions[:, None])
        moving[:, 0] = GEOM.ring_b_body.com                            # ring_b now rests
        a_com = np.einsum('kji,kj->ki', R, GEOM.ring_a_body.com - positions)
        moving = np.concatenate([moving, a_com[:, None]], axis=1)
        masses = np.concatenate([masses, [GEOM.ring_a_body.mass]])
        rest = 0.0
    accelerations = np.gradient(np.gradient(moving, h, axis=0), h, axis=0)
    force = np.einsum('b,kbi->ki', masses, accelerations) - (masses.sum() + rest) * g_support
    peak = np.linalg.norm(force[2:-2], axis=1).max()
    assert peak > (masses.sum() + rest) * 9.81 + 1.0                    # the motion shows
    assert result.peak_reaction_force == pytest.approx(peak, rel=0.02)


def test_a_motion_that_breaks_a_limit_is_reported_with_the_limit_the_leg_and_where():
    heavy = GEOM.with_(payload=Payload(ring='ring_b', mass=400.0, com=np.zeros(3),
                                       inertia=np.eye(3) * 4.0))
    result = preview_step(heavy, [_motion('ring_a')], drives=FAST, dt=DT, settle=SETTLE)
    assert not result.accepted and result.limit is PreviewLimit.ACTUATOR_FORCE
    assert result.peak_force > heavy.max_force
    assert f'leg_{result.peak_leg}' in result.detail and 'test move' in result.detail
    slipping = preview_step(GEOM, [_motion('ring_a')], drives=FAST, dt=DT, settle=SETTLE, min_margin=0.99)
    assert slipping.limit is PreviewLimit.HOLDING and slipping.min_margin_ring == 'ring_a'
    assert slipping.min_margin < 0.99 and 'holding: ring_a margin' in slipping.detail


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match='at least one motion'):
        preview_step(GEOM, [])
    with pytest.raises(ValueError, match='dt'):
        preview_step(GEOM, [_motion('ring_a')], dt=0.0)
    bad = PreviewMotion('bad', 'ring_a', WALL, np.zeros((3, 2)), np.zeros((3, 4)), DT)
    with pytest.raises(ValueError, match='bad: positions'):
        preview_step(GEOM, [bad])
