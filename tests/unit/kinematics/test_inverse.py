"""Inverse kinematics (eq. 1), leg frames and joint angles, the inverse Jacobian and statics."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rrps_description.geometry import load_robot
from rrps_description.rotations import (
    euler313_to_matrix,
    euler_parameters_to_matrix,
    quat_multiply_xyzw,
    quat_xyzw_to_matrix,
    rotation_vector_to_quat_xyzw,
)
from rrps_kinematics import (
    compiled_backend_available,
    inverse_jacobian,
    inverse_kinematics,
    leg_forces,
    leg_lengths,
    leg_rates,
    platform_wrench,
)
from rrps_testing.ci import require

SETTINGS = settings(max_examples=40, deadline=None)
ROBOTS = {name: load_robot(name) for name in ('pole_climber', 'frame_climber', 'master_robot')}


@st.composite
def poses(draw, robot='pole_climber'):
    """A pose near the workspace of ``robot``: home +- 40 % of the ring radius, +- 0.5 rad."""
    g = ROBOTS[robot]
    r = g.characteristic_length
    dp = draw(arrays(np.float64, 3, elements=st.floats(-0.4, 0.4, allow_nan=False)))
    rv = draw(arrays(np.float64, 3, elements=st.floats(-0.5, 0.5, allow_nan=False)))
    return g.home_position + r * dp, rotation_vector_to_quat_xyzw(rv)


def _batch(g, n, seed):
    rng = np.random.default_rng(seed)
    P = g.home_position + rng.uniform(-0.4, 0.4, (n, 3)) * g.characteristic_length
    Q = rotation_vector_to_quat_xyzw(rng.uniform(-0.5, 0.5, (n, 3)))
    return P, Q


@SETTINGS
@given(poses())
def test_leg_vectors_are_eq1(pose):
    g = ROBOTS['pole_climber']
    p, q = pose
    ik = inverse_kinematics(g, p, q)
    A_c = quat_xyzw_to_matrix(q)
    for i in range(6):
        r_ab = p + A_c @ g.ring_b_anchors[i] - g.ring_a_anchors[i]
        np.testing.assert_allclose(ik.leg_vectors[i], r_ab, atol=1e-15)
        assert ik.lengths[i] == pytest.approx(np.linalg.norm(r_ab), abs=1e-15)
        np.testing.assert_allclose(ik.ring_b_anchors_in_a[i], p + A_c @ g.ring_b_anchors[i], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(ik.unit_vectors, axis=1), 1.0, atol=1e-15)


@SETTINGS
@given(poses())
def test_leg_frames_euler_angles_and_parameters(pose):
    g = ROBOTS['pole_climber']
    ik = inverse_kinematics(g, *pose)
    F = ik.leg_frames
    np.testing.assert_allclose(F @ np.swapaxes(F, -1, -2), np.broadcast_to(np.eye(3), (6, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(F), 1.0, atol=1e-12)
    np.testing.assert_allclose(F[:, :, 2], ik.unit_vectors, atol=1e-15)  # u_z is the leg
    np.testing.assert_allclose(euler313_to_matrix(ik.leg_euler313), F, atol=1e-12)
    np.testing.assert_allclose(euler_parameters_to_matrix(ik.leg_euler_parameters), F, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(ik.leg_euler_parameters, axis=-1), 1.0, atol=1e-12)


@SETTINGS
@given(poses())
def test_universal_joint_angles_reproduce_the_leg_direction(pose):
    g = ROBOTS['pole_climber']
    ik = inverse_kinematics(g, *pose)
    R = ik.lower_link_rotations
    np.testing.assert_allclose(R[..., :, 2], ik.unit_vectors, atol=1e-12)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), (6, 3, 3)), atol=1e-12)
    assert np.all(np.abs(ik.universal_angles) <= np.pi)


def test_joint_angles_are_zero_at_home_with_default_axes():
    for g in ROBOTS.values():
        ik = inverse_kinematics(g, g.home_position, g.home_quaternion_xyzw)
        np.testing.assert_allclose(ik.universal_cone_angles, 0.0, atol=1e-12)
        np.testing.assert_allclose(ik.spherical_cone_angles, 0.0, atol=1e-12)


def test_cone_angles_from_tilted_neutral_axes():
    """Neutral axes tilted by known angles from the home legs give exactly those cone angles."""
    g = ROBOTS['pole_climber']
    home = g.home_position + g.ring_b_anchors - g.ring_a_anchors  # home_quaternion is identity
    u = home / np.linalg.norm(home, axis=1, keepdims=True)
    tilt = np.array([0.05, 0.1, 0.2, 0.3, 0.4, 0.6])
    n = np.cross(u, [0.0, 0.0, 1.0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    axes_a = np.array([quat_xyzw_to_matrix(rotation_vector_to_quat_xyzw(t * k)) @ ui
                       for t, k, ui in zip(tilt, n, u)])
    axes_b = np.array([quat_xyzw_to_matrix(rotation_vector_to_quat_xyzw(-t * k)) @ -ui
                       for t, k, ui in zip(tilt[::-1], n, u)])
    tilted = g.with_(ring_a_joint_axes=axes_a, ring_b_joint_axes=axes_b)
    ik = inverse_kinematics(tilted, g.home_position, g.home_quaternion_xyzw)
    np.testing.assert_allclose(ik.universal_cone_angles, tilt, atol=1e-12)
    np.testing.assert_allclose(ik.spherical_cone_angles, tilt[::-1], atol=1e-12)


@SETTINGS
@given(poses(), st.sampled_from(sorted(ROBOTS)))
def test_q_and_minus_q_give_the_same_legs(pose, robot):
    g = ROBOTS[robot]
    p = g.home_position + (pose[0] - ROBOTS['pole_climber'].home_position)
    a, b = inverse_kinematics(g, p, pose[1]), inverse_kinematics(g, p, -pose[1])
    np.testing.assert_allclose(a.lengths, b.lengths, atol=1e-15)
    # A non-unit quaternion is normalised first.
    np.testing.assert_allclose(inverse_kinematics(g, p, 3.0 * pose[1]).lengths, a.lengths, atol=1e-14)


@pytest.mark.parametrize('robot', sorted(ROBOTS))
def test_batch_equals_single(robot):
    g = ROBOTS[robot]
    P, Q = _batch(g, 25, 11)
    ik = inverse_kinematics(g, P, Q)
    names = ('leg_vectors', 'lengths', 'unit_vectors', 'leg_frames', 'leg_euler313',
             'leg_euler_parameters', 'universal_angles', 'universal_cone_angles',
             'spherical_cone_angles', 'lower_link_rotations')
    J = inverse_jacobian(ik)
    for k in range(len(P)):
        single = inverse_kinematics(g, P[k], Q[k])
        for name in names:
            np.testing.assert_allclose(getattr(ik, name)[k], getattr(single, name), atol=1e-12,
                                       err_msg=name)
        np.testing.assert_allclose(J[k], inverse_jacobian(single), atol=1e-12)
    # Any leading batch shape works.
    ik2 = inverse_kinematics(g, P.reshape(5, 5, 3), Q.reshape(5, 5, 4))
    np.testing.assert_allclose(ik2.lengths.reshape(25, 6), ik.lengths)


@pytest.mark.parametrize('backend', ['numpy', 'numba'])
def test_leg_lengths_fast_path(backend):
    require(backend != 'numba' or compiled_backend_available(), 'numba not available')
    g = ROBOTS['frame_climber']
    P, Q = _batch(g, 500, 5)
    ref = inverse_kinematics(g, P, Q).lengths
    np.testing.assert_allclose(leg_lengths(g, P, Q, backend=backend), ref, atol=1e-14)
    np.testing.assert_allclose(leg_lengths(g, P[3], Q[3], backend=backend), ref[3], atol=1e-14)
    np.testing.assert_allclose(leg_lengths(g, P[:4], 2.0 * Q[:4], backend=backend), ref[:4], atol=1e-14)


@pytest.mark.parametrize('position,quaternion,message', [
    ([0, 0], [0, 0, 0, 1], 'position must have shape'),
    ([0, 0, 0.4], [0, 0, 1], 'quaternion_xyzw must have shape'),
    ([[0, 0, 0.4]] * 2, [[0, 0, 0, 1]] * 3, 'batch shapes differ'),
    ([0, np.nan, 0.4], [0, 0, 0, 1], 'NaN'),
    ([0, 0, 0.4], [0, 0, np.inf, 1], 'NaN or infinite'),
    ([0, 0, 0.4], [0, 0, 0, 0], 'zero norm'),
])
def test_bad_poses_raise_value_error(position, quaternion, message):
    g = ROBOTS['pole_climber']
    with pytest.raises(ValueError, match=message):
        inverse_kinematics(g, position, quaternion)
    with pytest.raises(ValueError, match=message):
        leg_lengths(g, position, quaternion)


@SETTINGS
@given(poses(), arrays(np.float64, 6, elements=st.floats(-1.0, 1.0, allow_nan=False)))
def test_inverse_jacobian_matches_finite_differences(pose, twist):
    """Leg rates J @ (v, omega) equal the central difference of the lengths along the twist."""
    g = ROBOTS['pole_climber']
    p, q = pose
    h = 1e-6
    def turned(sign):
        return quat_multiply_xyzw(rotation_vector_to_quat_xyzw(sign * h * twist[3:]), q)
    plus = inverse_kinematics(g, p + h * twist[:3], turned(1.0))
    minus = inverse_kinematics(g, p - h * twist[:3], turned(-1.0))
    numeric = (plus.lengths - minus.lengths) / (2 * h)
    np.testing.assert_allclose(leg_rates(inverse_kinematics(g, p, q), twist), numeric, atol=1e-7)


@SETTINGS
@given(poses(), arrays(np.float64, 6, elements=st.floats(-100.0, 100.0, allow_nan=False)))
def test_statics_by_virtual_work(pose, wrench):
    g = ROBOTS['pole_climber']
    ik = inverse_kinematics(g, *pose)
    f = leg_forces(ik, wrench)
    np.testing.assert_allclose(platform_wrench(ik, f), -wrench, atol=1e-8 * (1 + np.abs(f).max()))
    # Power balance: actuator power f . ldot equals the wrench J^T f times the twist.
    twist = np.array([0.1, -0.2, 0.05, 0.3, 0.1, -0.2])
    assert f @ leg_rates(ik, twist) == pytest.approx(platform_wrench(ik, f) @ twist, rel=1e-9, abs=1e-9)


def test_leg_forces_at_a_singular_pose_raise():
    g = ROBOTS['pole_climber']
    flat = g.with_(ring_b_anchors=np.zeros((6, 3)))
    ik = inverse_kinematics(flat, flat.home_position, flat.home_quaternion_xyzw)
    with pytest.raises(np.linalg.LinAlgError):
        leg_forces(ik, np.ones(6))
