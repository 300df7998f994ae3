"""Inverse dynamics (rrps_loads.inverse_dynamics): actuator forces along a prescribed trajectory,
checked by driving the reduced model and the multibody DAE with them."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicSpline

from rrps_description.geometry import RobotGeometry, load_robot
from rrps_description.rotations import quat_multiply_xyzw, rotation_vector_to_quat_xyzw
from rrps_loads.inverse_dynamics import inverse_dynamics, sample_derivatives, trajectory_twists
from rrps_loads.reduced import (
    PlatformPose,
    generalized_forces,
    platform_accelerations,
    simulate_reduced,
)
from rrps_loads.statics import holding_forces, solve_actuator_forces
from rrps_sim.dynamics import simulate

DURATION = 0.5


def _trajectory(geom, t, shift=(0.02, -0.01, 0.03), turn=(0.05, -0.03, 0.08)):
    """Rest-to-rest ring_b motion: blend s(t) = (1 - cos(pi t / T)) / 2 of a shift and a turn."""
    s = 0.5 * (1.0 - np.cos(np.pi * np.asarray(t) / DURATION))
    p = geom.home_position + s[:, None] * np.asarray(shift)
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(s[:, None] * np.asarray(turn)),
                           geom.home_quaternion_xyzw)
    return p, q


@functools.lru_cache(maxsize=None)
def _planned(robot, dt):
    geom = load_robot(robot)
    t = dt * np.arange(int(round(DURATION / dt)) + 1)
    p, q = _trajectory(geom, t)
    return geom, t, p, q, inverse_dynamics(geom, t, p, q)


def _interpolated(t, F, time):
    return np.array([np.interp(time, t, F[:, i]) for i in range(6)])


def test_at_rest_the_forces_are_the_holding_forces():
    geom = load_robot('facade_climber')
    t = np.linspace(0.0, 1.0, 11)
    p = np.tile(geom.home_position + [0.03, -0.02, 0.01], (11, 1))
    q = np.tile(rotation_vector_to_quat_xyzw(np.array([0.05, 0.02, -0.1])), (11, 1))
    F = inverse_dynamics(geom, t, p, q)
    np.testing.assert_allclose(F, np.tile(holding_forces(geom, p[0], q[0]), (11, 1)), atol=1e-9)


def test_trajectory_twists_converge_at_orders_6_and_5_to_the_analytic_twists():
    """Position: a degree-6 polynomial, which 7-point differences reproduce exactly. Rotation:
    angle theta(t) about a fixed axis n, so omega = theta' n and omega_dot = theta'' n exactly;
    halving the step divides the errors by 2^6 and 2^5, at every sample, the ends included."""
    n = np.array([1.0, -2.0, 2.0]) / 3.0
    c = np.array([[0.1, -0.2, 0.3], [0.5, 0.1, -0.4], [-0.3, 0.2, 0.1], [0.2, 0.1, -0.1],
                  [-0.1, 0.05, 0.2], [0.03, -0.02, 0.01], [0.01, 0.02, -0.03]])

    def errors(dt):
        t = np.arange(0.0, 1.0 + dt / 2, dt)
        theta, dtheta, ddtheta = 0.4 * np.sin(2 * t), 0.8 * np.cos(2 * t), -1.6 * np.sin(2 * t)
        p = sum(c[i] * t[:, None] ** i for i in range(7))
        v = sum(i * c[i] * t[:, None] ** (i - 1) for i in range(1, 7))
        a = sum(i * (i - 1) * c[i] * t[:, None] ** (i - 2) for i in range(2, 7))
        twist, twist_dot = trajectory_twists(t, p, rotation_vector_to_quat_xyzw(theta[:, None] * n))
        np.testing.assert_allclose(twist[:, :3], v, atol=1e-12)
        np.testing.assert_allclose(twist_dot[:, :3], a, atol=1e-9)
        return (np.abs(twist[:, 3:] - dtheta[:, None] * n).max(),
                np.abs(twist_dot[:, 3:] - ddtheta[:, None] * n).max())

    coarse, fine = errors(0.01), errors(0.005)
    assert fine[0] < 1e-12 and fine[1] < 1e-9
    assert fine[0] < coarse[0] / 40 and fine[1] < coarse[1] / 20   # 2^6 = 64, 2^5 = 32


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(0.5, 1.5), min_size=12, max_size=40),
       st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7))
def test_sample_derivatives_are_exact_for_degree_6_on_any_spacing(gaps, coefficients):
    t = 0.01 * np.cumsum(gaps)
    y = np.polynomial.Polynomial(coefficients)
    first, second = sample_derivatives(t, y(t)[:, None])
    scale = 1.0 + np.abs(np.polynomial.Polynomial(np.abs(coefficients))(t.max())) / t.max() ** 2
    np.testing.assert_allclose(first[:, 0], y.deriv(1)(t), atol=1e-11 * scale)
    np.testing.assert_allclose(second[:, 0], y.deriv(2)(t), atol=1e-9 * scale)


def _exact_trajectory(geom, t, period=0.5, shift=(0.02, -0.01, 0.03), turn=(0.05, -0.03, 0.08)):
    """s(t) = (1 - cos(2 pi t / T)) / 2 along a shift and a turn about a fixed axis, with the
    exact twist (v = s' shift, omega = s' turn) and its rate (s'' shift, s'' turn)."""
    w = 2 * np.pi / period
    s, ds, dds = 0.5 * (1 - np.cos(w * t)), 0.5 * w * np.sin(w * t), 0.5 * w**2 * np.cos(w * t)
    shift, turn = np.asarray(shift), np.asarray(turn)
    p = geom.home_position + s[:, None] * shift
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(s[:, None] * turn),
                           geom.home_quaternion_xyzw)
    twist = np.concatenate([ds[:, None] * shift, ds[:, None] * turn], axis=1)
    twist_dot = np.concatenate([dds[:, None] * shift, dds[:, None] * turn], axis=1)
    pose = PlatformPose(geom, p, q)
    exact = solve_actuator_forces(pose, generalized_forces(pose, twist, twist_dot))
    return p, q, twist, twist_dot, exact


@pytest.mark.parametrize('robot', ['pole_climber', 'frame_climber'])
def test_forces_from_positions_at_1_khz_are_within_1e_4_n_of_the_exact_forces(robot):
    geom = load_robot(robot)
    t = np.arange(0.0, 0.5 + 5e-4, 1e-3)
    p, q, twist, twist_dot, exact = _exact_trajectory(geom, t)
    assert np.abs(exact).max() > 10.0 and np.ptp(exact, axis=0).max() > 1.0   # it moves
    error = np.abs(inverse_dynamics(geom, t, p, q) - exact).max()
    given = np.abs(inverse_dynamics(geom, t, p, q, twist=twist, twist_dot=twist_dot) - exact).max()
    rates = np.abs(inverse_dynamics(geom, t, p, q, twist=twist) - exact).max()
    accelerations = np.abs(inverse_dynamics(geom, t, p, q, twist_dot=twist_dot) - exact).max()
    print(f'{robot}: max force error from positions {error:.2e} N, with velocities '
          f'{rates:.2e} N, with accelerations {accelerations:.2e} N, with both {given:.2e} N')
    assert error <= 1e-4
    assert given <= 1e-12 * np.abs(exact).max()
    assert rates <= 1e-6 and accelerations <= 1e-6


def test_given_derivatives_are_checked():
    geom, t, p, q, _ = _planned('frame_climber', 0.01)
    for kwargs, match in ((dict(twist=np.zeros((len(t), 5))), 'twist must have shape'),
                          (dict(twist_dot=np.full((len(t), 6), np.nan)), 'twist_dot contains NaN')):
        with pytest.raises(ValueError, match=match):
            inverse_dynamics(geom, t, p, q, **kwargs)


@settings(max_examples=15, deadline=None)
@given(st.sampled_from(['pole_climber', 'frame_climber', 'master_robot']),
       st.lists(st.floats(-0.08, 0.08), min_size=3, max_size=3),
       st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3))
def test_forward_dynamics_under_the_forces_gives_the_prescribed_accelerations(robot, shift, turn):
    geom = load_robot(robot)
    t = np.linspace(0.0, DURATION, 26)
    p, q = _trajectory(geom, t, geom.characteristic_length * np.array(shift), turn)
    F = inverse_dynamics(geom, t, p, q)
    twist, twist_dot = trajectory_twists(t, p, q)
    acc = platform_accelerations(PlatformPose(geom, p, q), twist, F)
    np.testing.assert_allclose(acc, twist_dot, atol=1e-9 * (1.0 + np.abs(twist_dot).max()))


def test_the_reduced_model_driven_by_the_forces_tracks_the_trajectory():
    geom, t, p, q, F = _planned('pole_climber', 0.001)
    force = CubicSpline(t, F, axis=0)   # smooth in time, as the adaptive integrator prefers
    run = simulate_reduced(geom, p[0], q[0], lambda time, state: force(time), DURATION, 0.001)
    assert np.abs(run.position - p).max() <= 1e-6
    assert np.abs(np.abs(np.sum(run.quaternion_xyzw * q, axis=1)) - 1.0).max() <= 1e-12
    # Holding forces alone would not make this motion: the dynamic part matters.
    hold = holding_forces(geom, p[0], q[0])
    assert np.abs(F - hold).max() > 1.0


@pytest.mark.parametrize('robot', ['pole_climber', 'facade_climber'])
def test_the_multibody_dae_driven_by_the_forces_tracks_the_trajectory(robot):
    """The DAE holds each step's force over the step: sample the forces at the step midpoint."""
    geom, t, p, q, F = _planned(robot, 0.001)
    run = simulate(geom, p[0], q[0], lambda time, dyn: _interpolated(t, F, time + 0.0005),
                   duration=DURATION, dt=0.001, method='hybrid')
    moved = np.abs(p - p[0]).max()
    error = np.abs(run.position - p).max()
    assert error <= 1e-6, f'tracking error {error:.3g} m on a {moved:.3g} m motion'
    assert np.abs(np.abs(np.sum(run.quaternion_xyzw * q, axis=1)) - 1.0).max() <= 1e-10


def test_quaternion_signs_and_a_time_shift_do_not_change_the_forces():
    geom, t, p, q, F = _planned('frame_climber', 0.01)
    flipped = q * np.where(np.arange(len(t)) % 3 == 1, -1.0, 1.0)[:, None]
    np.testing.assert_allclose(inverse_dynamics(geom, t + 12.5, p, flipped), F, atol=1e-8)


def test_rejects_invalid_trajectories():
    geom, t, p, q, _ = _planned('frame_climber', 0.01)
    cases = (
        ((t[::-1], p, q), 'increasing'),
        ((np.r_[t[:3], t[2], t[4:]], p, q), 'increasing'),
        ((t[:3], p[:3], q[:3]), 'at least 4'),
        ((t, p[:, :2], q), 'positions'),
        ((t, p, q[:-1]), 'quaternions_xyzw'),
        ((t.reshape(-1, 1), p, q), '1-D'),
        ((np.where(t == t[5], np.nan, t), p, q), 'NaN'),
        ((t, np.where(p == p[3, 1], np.inf, p), q), 'NaN'),
        ((t, p, np.vstack([q[:-1], np.zeros(4)])), 'zero quaternion'),
    )
    for args, match in cases:
        with pytest.raises(ValueError, match=match):
            inverse_dynamics(geom, *args)


def test_a_singular_pose_on_the_way_raises():
    geom = load_robot('pole_climber')
    pointed = RobotGeometry(ring_a_anchors=geom.ring_a_anchors, ring_b_anchors=np.zeros((6, 3)))
    t = np.linspace(0.0, DURATION, 6)
    p, q = _trajectory(pointed, t)
    with pytest.raises(ValueError, match='singular'):
        inverse_dynamics(pointed, t, p, q)
