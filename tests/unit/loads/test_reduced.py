"""Reduced 6-DOF model (rrps_loads.reduced): its kinematics, energy, and the cross-check against
the 91-coordinate multibody DAE of rrps_sim.dynamics."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.robot_parts import LinkInertia
from rrps_description.rotations import (
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    quat_xyzw_to_matrix,
    quat_xyzw_to_rotation_vector,
    rotation_vector_to_quat_xyzw,
)
from rrps_description.world import STANDARD_GRAVITY
from rrps_kinematics.inverse import lower_link_rotations
from rrps_loads.reduced import (
    PlatformPose,
    body_accelerations,
    body_velocities,
    generalized_forces,
    kinetic_energy,
    mass_matrix,
    platform_accelerations,
    simulate_reduced,
)
from rrps_loads.statics import holding_forces
from rrps_sim.dynamics import simulate

ROBOTS = ['pole_climber', 'frame_climber', 'facade_climber', 'master_robot']


def _pose_path(geom, t):
    """A smooth ring_b path around home, scaled to the robot: (position, quaternion) at t [s]."""
    s = geom.characteristic_length
    p = geom.home_position + s * np.array([0.06 * np.sin(3 * t), -0.04 * t**2, 0.08 * np.cos(2 * t)])
    rv = np.array([0.1 * np.sin(t), 0.05 * t, -0.08 * np.cos(1.5 * t)])
    return p, quat_multiply_xyzw(rotation_vector_to_quat_xyzw(rv), geom.home_quaternion_xyzw)


def _path_twist(geom, t, h=1e-5):
    (p1, q1), (p0, q0) = _pose_path(geom, t + h), _pose_path(geom, t - h)
    dq = quat_multiply_xyzw(q1, q0 * np.array([-1, -1, -1, 1.0]))
    return np.concatenate([(p1 - p0) / (2 * h), quat_xyzw_to_rotation_vector(dq) / (2 * h)])


def _bodies(geom, t):
    """Com positions, link rotations (from the IK's universal angles) and lengths at t."""
    pose = PlatformPose(geom, *_pose_path(geom, t))
    ring = pose.position[0] + pose.com_b[0]
    lower = geom.ring_a_anchors + geom.lower_link.com_from_joint * pose.u[0]
    upper = pose.ik.ring_b_anchors_in_a[0] - geom.upper_link.com_from_joint * pose.u[0]
    links = lower_link_rotations(geom, pose.ik.universal_angles)[0]
    return ring, lower, upper, links, pose.lengths[0]


@pytest.mark.parametrize('robot', ROBOTS)
def test_body_velocities_are_the_derivatives_of_body_positions_and_link_rotations(robot):
    geom = load_robot(robot)
    t0, h = 0.7, 1e-5
    pose = PlatformPose(geom, *_pose_path(geom, t0))
    V = body_velocities(pose, _path_twist(geom, t0)[None])
    after, before = _bodies(geom, t0 + h), _bodies(geom, t0 - h)
    scale = geom.characteristic_length
    for k, got in ((0, V.ring[0]), (1, V.lower[0]), (2, V.upper[0]), (4, V.leg_rates[0])):
        np.testing.assert_allclose(got, (after[k] - before[k]) / (2 * h), atol=1e-8 * scale)
    # The link angular velocity is that of F_i Rx(theta1) Ry(theta2): no free spin about the leg.
    R = _bodies(geom, t0)[3]
    W = (after[3] - before[3]) / (2 * h) @ np.swapaxes(R, -1, -2)
    omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)
    np.testing.assert_allclose(V.link_angular[0], omega, atol=1e-8)
    assert np.max(np.abs(np.einsum('ij,ij->i', omega, pose.u[0]))) > 1e-4  # the spin is there


@pytest.mark.parametrize('robot', ['pole_climber', 'facade_climber'])
def test_body_accelerations_are_the_derivatives_of_body_velocities(robot):
    geom = load_robot(robot)
    t0, h = 0.4, 1e-4
    pose = PlatformPose(geom, *_pose_path(geom, t0))
    twist_dot = (_path_twist(geom, t0 + h) - _path_twist(geom, t0 - h)) / (2 * h)
    A = body_accelerations(pose, _path_twist(geom, t0)[None], twist_dot[None])

    def velocities(t):
        return body_velocities(PlatformPose(geom, *_pose_path(geom, t)), _path_twist(geom, t)[None])

    va, vb = velocities(t0 + h), velocities(t0 - h)
    for name in ('ring', 'ring_angular', 'lower', 'upper', 'link_angular', 'leg_rates'):
        np.testing.assert_allclose(getattr(A, name), (getattr(va, name) - getattr(vb, name)) / (2 * h),
                                   atol=1e-7, err_msg=name)


poses = st.tuples(
    st.sampled_from(ROBOTS),
    st.lists(st.floats(-0.08, 0.08), min_size=3, max_size=3),
    st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3),
    st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    st.lists(st.floats(-5.0, 5.0), min_size=6, max_size=6),
)


def _pose_of(robot, dp, rv):
    geom = load_robot(robot)
    p = geom.home_position + geom.characteristic_length * np.array(dp)
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.array(rv)), geom.home_quaternion_xyzw)
    return geom, PlatformPose(geom, p, q)


@settings(max_examples=25, deadline=None)
@given(poses)
def test_mass_matrix_is_symmetric_positive_definite_and_gives_the_kinetic_energy(sample):
    robot, dp, rv, twist, twist_dot = sample
    geom, pose = _pose_of(robot, dp, rv)
    M = mass_matrix(pose)[0]
    np.testing.assert_allclose(M, M.T, atol=1e-14 * np.abs(M).max())
    assert np.linalg.eigvalsh(M)[0] > 0.0
    t = np.array(twist)
    assert kinetic_energy(pose, t[None])[0] == pytest.approx(0.5 * t @ M @ t, rel=1e-12, abs=1e-15)
    # Kane's equations are affine in the twist rate, with M as the slope.
    Q1 = generalized_forces(pose, t[None], np.array(twist_dot)[None])[0]
    Q0 = generalized_forces(pose, t[None], np.zeros((1, 6)))[0]
    np.testing.assert_allclose(Q1 - Q0, M @ np.array(twist_dot), atol=1e-10 * (1 + np.abs(Q1).max()))
    np.testing.assert_allclose(body_velocities(pose, t[None]).leg_rates[0],
                               pose.inverse_jacobian[0] @ t, atol=1e-13)


def _light_legs(geom):
    light = LinkInertia(mass=1e-12, com_from_joint=0.1, inertia_transverse=1e-15, inertia_axial=1e-15)
    return geom.with_(lower_link=light, upper_link=light)


def test_with_massless_legs_ring_b_falls_freely_and_spins_torque_free():
    geom = _light_legs(load_robot('pole_climber'))
    p0, q0 = geom.home_position, geom.home_quaternion_xyzw
    v0, w0 = np.array([0.1, -0.05, 0.2]), np.array([0.4, -0.3, 0.9])
    r = simulate_reduced(geom, p0, q0, np.zeros(6), 0.2, 0.01, velocity=v0, angular_velocity=w0)
    com_b = geom.ring_b_body.com
    com = r.position + np.einsum('kij,j->ki', quat_xyzw_to_matrix(r.quaternion_xyzw), com_b)
    com0 = p0 + quat_xyzw_to_matrix(q0) @ com_b
    vcom0 = v0 + np.cross(w0, quat_xyzw_to_matrix(q0) @ com_b)
    expected = com0 + np.outer(r.t, vcom0) + 0.5 * np.outer(r.t**2, STANDARD_GRAVITY)
    np.testing.assert_allclose(com, expected, atol=1e-9)
    R = quat_xyzw_to_matrix(r.quaternion_xyzw)
    momentum = np.einsum('kij,jl,kml,km->ki', R, geom.ring_b_body.inertia, R, r.angular_velocity)
    np.testing.assert_allclose(momentum, np.broadcast_to(momentum[0], momentum.shape), atol=1e-10)
    assert np.linalg.norm(r.angular_velocity[-1] - w0) > 1e-2  # a real tumble, not a trivial spin


def test_energy_is_conserved_with_zero_actuator_work():
    geom = load_robot('pole_climber')
    r = simulate_reduced(geom, geom.home_position, geom.home_quaternion_xyzw, np.zeros(6), 0.2, 0.005,
                         velocity=(0.05, -0.02, 0.1), angular_velocity=(0.3, 0.1, -0.2))
    assert np.all(r.actuator_work == 0.0)
    energy = r.kinetic_energy + r.potential_energy
    assert np.ptp(r.kinetic_energy) > 1.0       # it falls: energy moves from V to T
    assert np.ptp(energy) < 1e-8


def test_energy_balance_with_constant_forces():
    geom = load_robot('facade_climber')
    p0, q0 = geom.home_position, geom.home_quaternion_xyzw
    f = holding_forces(geom, p0, q0) + np.array([3.0, -2.0, 1.0, 2.5, -1.5, 0.5])
    r = simulate_reduced(geom, p0, q0, f, 0.3, 0.01)
    # For constant forces the actuator work is f . (L - L0): checks the integrated work state.
    np.testing.assert_allclose(r.actuator_work, (r.lengths - r.lengths[0]) @ f, atol=1e-10)
    assert np.ptp(r.kinetic_energy) > 1e-3
    assert np.ptp(r.energy_balance) < 1e-9


def test_simulate_reduced_rejects_bad_input():
    geom = load_robot('pole_climber')
    p0, q0 = geom.home_position, geom.home_quaternion_xyzw
    for kwargs, match in (
            (dict(forces=np.zeros(5), duration=0.1, dt=0.01), 'shape'),
            (dict(forces=np.full(6, np.nan), duration=0.1, dt=0.01), 'NaN'),
            (dict(forces=np.zeros(6), duration=-0.1, dt=0.01), 'duration'),
            (dict(forces=np.zeros(6), duration=0.1, dt=0.0), 'dt'),
            (dict(forces=np.zeros(6), duration=0.1, dt=0.03), 'multiple'),
            (dict(forces=lambda t, s: np.zeros(3), duration=0.1, dt=0.01), 'shape'),
    ):
        with pytest.raises(ValueError, match=match):
            simulate_reduced(geom, p0, q0, **kwargs)
    with pytest.raises(ValueError):
        simulate_reduced(geom, [0.0, np.nan, 0.3], q0, np.zeros(6), 0.1, 0.01)
    with pytest.raises(ValueError):
        simulate_reduced(geom, p0, np.zeros(4), np.zeros(6), 0.1, 0.01)


# --- cross-check against the multibody DAE ----------------------------------------------------

def _constant_force_run(geom, reach=0.06):
    """The paper's 0.5 s run: at rest at an off-home pose, holding forces plus a constant push
    sized so that ring_b's initial acceleration would carry it ``reach`` x the robot's size in
    0.5 s."""
    s = geom.characteristic_length
    p0 = geom.home_position + s * np.array([0.06, -0.03, 0.05])
    q0 = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.array([0.06, -0.04, 0.1])),
                            geom.home_quaternion_xyzw)
    hold = holding_forces(geom, p0, q0)
    pattern = np.array([1.5, -1.0, 0.5, 1.0, -0.5, 0.8])
    pose = PlatformPose(geom, p0, q0)
    acceleration = platform_accelerations(pose, np.zeros((1, 6)), (hold + pattern)[None])[0, :3]
    return p0, q0, hold + pattern * (reach * s / (0.5 * 0.5**2 * np.linalg.norm(acceleration)))


@functools.lru_cache(maxsize=None)
def _reduced_run(robot):
    geom = load_robot(robot)
    p0, q0, f = _constant_force_run(geom)
    return geom, p0, q0, f, simulate_reduced(geom, p0, q0, f, 0.5, 0.001)


@pytest.mark.parametrize('robot,method', [('pole_climber', 'hybrid'), ('pole_climber', 'baumgarte'),
                                          ('pole_climber', 'partitioning'),
                                          ('frame_climber', 'hybrid'), ('master_robot', 'hybrid')])
def test_constant_force_run_agrees_with_the_multibody_dae(robot, method):
    geom, p0, q0, f, reduced = _reduced_run(robot)
    multibody = simulate(geom, p0, q0, f, duration=0.5, dt=0.001, method=method)
    np.testing.assert_allclose(multibody.t, reduced.t, atol=1e-12)
    # A visible motion that stays inside the actuator stroke.
    assert np.linalg.norm(reduced.position[-1] - p0) > 0.02 * geom.characteristic_length
    assert geom.min_length < reduced.lengths.min() and reduced.lengths.max() < geom.max_length
    position_error = np.abs(multibody.position - reduced.position).max()
    assert position_error <= 1e-6, f'positions differ by {position_error:.3g} m'
    np.testing.assert_allclose(multibody.lengths, reduced.lengths, atol=1e-6)
    turn = quat_multiply_xyzw(quat_conjugate_xyzw(reduced.quaternion_xyzw),
                              multibody.quaternion_xyzw)
    assert np.max(2 * np.arctan2(np.linalg.norm(turn[:, :3], axis=1), np.abs(turn[:, 3]))) <= 1e-6
    # Both models also carry the same energy along the run.
    np.testing.assert_allclose(multibody.kinetic, reduced.kinetic_energy,
                               atol=1e-6 * reduced.kinetic_energy.max())
    np.testing.assert_allclose(multibody.potential - multibody.potential[0],
                               reduced.potential_energy - reduced.potential_energy[0], atol=1e-8)


def test_cross_check_resolves_the_link_spin_about_the_leg():
    """With heavy axial link inertias the spin the U-joint imposes moves ring_b by far more than
    the 1e-6 m tolerance; the two models must still agree, so they model the spin the same way."""
    base = load_robot('pole_climber')

    def spinning(link, axial):
        return LinkInertia(mass=link.mass, com_from_joint=link.com_from_joint,
                           inertia_transverse=link.inertia_transverse, inertia_axial=axial)

    heavy = base.with_(lower_link=spinning(base.lower_link, 2 * base.lower_link.inertia_transverse),
                       upper_link=spinning(base.upper_link, 2 * base.upper_link.inertia_transverse))
    light = base.with_(lower_link=spinning(base.lower_link, 1e-9),
                       upper_link=spinning(base.upper_link, 1e-9))
    p0, q0, f = _constant_force_run(heavy, reach=0.12)
    reduced = simulate_reduced(heavy, p0, q0, f, 0.5, 0.001)
    assert heavy.min_length < reduced.lengths.min() and reduced.lengths.max() < heavy.max_length
    no_spin = simulate_reduced(light, p0, q0, f, 0.5, 0.001)
    assert np.abs(no_spin.position - reduced.position).max() > 1e-5
    multibody = simulate(heavy, p0, q0, f, duration=0.5, dt=0.001, method='hybrid')
    assert np.abs(multibody.position - reduced.position).max() <= 1e-6
