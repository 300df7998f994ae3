"""Statics (rrps_loads.statics): holding forces by virtual work, checked against the gravity
potential, the pose-level statics of rrps_kinematics and the multibody Lagrange multipliers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import RobotGeometry, load_robot
from rrps_description.robot_parts import LinkInertia
from rrps_description.rotations import quat_multiply_xyzw, quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_description.world import STANDARD_GRAVITY
from rrps_kinematics import inverse_kinematics, leg_forces
from rrps_loads.reduced import PlatformPose, generalized_forces, simulate_reduced
from rrps_loads.statics import holding_forces, static_load
from rrps_sim.dynamics import MultibodyDynamics, simulate

ROBOTS = ['pole_climber', 'frame_climber', 'facade_climber', 'master_robot']


def _pose(geom, dp, rv):
    p = geom.home_position + geom.characteristic_length * np.asarray(dp, dtype=float)
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.asarray(rv, dtype=float)),
                           geom.home_quaternion_xyzw)
    return p, q


def _gravity_potential(geom, p, q):
    """-sum m g . com over ring_b and the 12 links, written from the robot description alone."""
    R = quat_xyzw_to_matrix(q)
    b = p + geom.ring_b_anchors @ R.T
    u = (b - geom.ring_a_anchors) / np.linalg.norm(b - geom.ring_a_anchors, axis=1)[:, None]
    lower = geom.ring_a_anchors + geom.lower_link.com_from_joint * u
    upper = b - geom.upper_link.com_from_joint * u
    coms = np.vstack([p + R @ geom.ring_b_body.com, lower, upper])
    masses = np.r_[geom.ring_b_body.mass, [geom.lower_link.mass] * 6, [geom.upper_link.mass] * 6]
    return -float(masses @ (coms @ np.array(STANDARD_GRAVITY)))


pose_samples = st.tuples(
    st.sampled_from(ROBOTS),
    st.lists(st.floats(-0.08, 0.08), min_size=3, max_size=3),
    st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3),
    st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6).filter(lambda d: np.linalg.norm(d) > 0.1),
)


@settings(max_examples=30, deadline=None)
@given(pose_samples)
def test_holding_forces_balance_gravity_by_virtual_work(sample):
    """For any small motion of ring_b, the actuators' work f . dl equals the rise of V."""
    robot, dp, rv, direction = sample
    geom = load_robot(robot)
    p, q = _pose(geom, dp, rv)
    f = holding_forces(geom, p, q)
    d = np.asarray(direction) / np.linalg.norm(direction)
    h = 1e-5
    step = [(p + s * h * d[:3],
             quat_multiply_xyzw(rotation_vector_to_quat_xyzw(s * h * d[3:]), q)) for s in (1, -1)]
    dV = (_gravity_potential(geom, *step[0]) - _gravity_potential(geom, *step[1])) / (2 * h)
    dl = (inverse_kinematics(geom, *step[0]).lengths - inverse_kinematics(geom, *step[1]).lengths) / (2 * h)
    weight = 9.81 * (geom.ring_b_body.mass + 6 * (geom.lower_link.mass + geom.upper_link.mass))
    assert f @ dl == pytest.approx(dV, abs=1e-7 * weight)


def test_with_massless_legs_the_forces_are_the_pose_level_statics():
    geom = load_robot('facade_climber')
    light = LinkInertia(mass=1e-12, com_from_joint=0.1, inertia_transverse=1e-15, inertia_axial=1e-15)
    geom = geom.with_(lower_link=light, upper_link=light)
    p, q = _pose(geom, [0.05, -0.02, 0.04], [0.1, 0.05, -0.2])
    ik = inverse_kinematics(geom, p, q)
    weight = geom.ring_b_body.mass * np.array(STANDARD_GRAVITY)
    moment = np.cross(quat_xyzw_to_matrix(q) @ geom.ring_b_body.com, weight)
    expected = leg_forces(ik, np.concatenate([weight, moment]))
    np.testing.assert_allclose(holding_forces(geom, p, q), expected, atol=1e-9)


def test_the_legs_weight_is_carried_too():
    geom = load_robot('frame_climber')
    p, q = geom.home_position, geom.home_quaternion_xyzw
    with_legs = holding_forces(geom, p, q)
    light = LinkInertia(mass=1e-12, com_from_joint=0.1, inertia_transverse=1e-15, inertia_axial=1e-15)
    ring_alone = holding_forces(geom.with_(lower_link=light, upper_link=light), p, q)
    # Upper links hang on ring_b; lower links lean on ring_a: the legs add a load of their own.
    assert np.all(with_legs > ring_alone + 1.0)


def test_a_mirror_symmetric_robot_needs_mirror_symmetric_forces():
    geom = load_robot('pole_climber')      # anchors mirror about ring_a's x-z plane
    f = holding_forces(geom, geom.home_position, geom.home_quaternion_xyzw)
    np.testing.assert_allclose(f[[1, 5, 4]], f[[0, 2, 3]], rtol=1e-12)
    assert np.all(f > 0.0)                 # the legs push ring_b up against gravity


def test_a_batch_of_poses_gives_the_same_forces_as_single_poses():
    geom = load_robot('pole_climber')
    poses = [_pose(geom, [0.02 * k, -0.01 * k, 0.03], [0.05, -0.02 * k, 0.1]) for k in range(3)]
    P = np.array([p for p, _ in poses])
    Q = np.array([q for _, q in poses])
    batch = holding_forces(geom, P, Q)
    assert batch.shape == (3, 6)
    for k, (p, q) in enumerate(poses):
        np.testing.assert_allclose(batch[k], holding_forces(geom, p, q), rtol=1e-13, atol=1e-12)


@pytest.mark.parametrize('robot', ROBOTS)
def test_agrees_with_the_multibody_lagrange_multipliers(robot):
    geom = load_robot(robot)
    multibody = MultibodyDynamics(geom)
    for dp, rv in (([0, 0, 0], [0, 0, 0]), ([0.06, -0.03, 0.05], [0.06, -0.04, 0.1]),
                   ([-0.05, 0.07, -0.04], [-0.12, 0.08, -0.15])):
        p, q = _pose(geom, dp, rv)
        ours = holding_forces(geom, p, q)
        theirs = multibody.holding_forces(p, q)
        assert np.max(np.abs(ours - theirs)) <= 1e-6, f'{robot} {dp} {rv}: {ours} vs {theirs}'


def test_a_pose_held_by_the_forces_stays_at_rest_in_both_models():
    geom = load_robot('pole_climber')
    p, q = _pose(geom, [0.06, -0.03, 0.05], [0.06, -0.04, 0.1])
    f = holding_forces(geom, p, q)
    reduced = simulate_reduced(geom, p, q, f, 0.5, 0.001)
    multibody = simulate(geom, p, q, f, duration=0.5, dt=0.001, method='hybrid')
    for run in (reduced, multibody):
        assert np.abs(run.position - p).max() <= 1e-9
        assert np.abs(np.abs(run.quaternion_xyzw @ q) - 1.0).max() <= 1e-12
    # A 0.1 % error in the forces would not hold it: the check above has teeth.
    drifting = simulate_reduced(geom, p, q, 1.001 * f, 0.5, 0.001)
    assert np.abs(drifting.position - p).max() > 1e-5


def test_rejects_invalid_input():
    geom = load_robot('pole_climber')
    p, q = geom.home_position, geom.home_quaternion_xyzw
    with pytest.raises(ValueError, match='NaN'):
        holding_forces(geom, [0.0, np.nan, 0.4], q)
    with pytest.raises(ValueError, match='shape'):
        holding_forces(geom, p, q[:3])
    with pytest.raises(ValueError, match='zero norm'):
        holding_forces(geom, p, np.zeros(4))
    with pytest.raises(ValueError, match='RobotGeometry'):
        holding_forces('pole_climber', p, q)


def test_a_singular_pose_raises():
    """All spherical joints at one point: ring_b can turn about it freely, no forces hold it."""
    geom = load_robot('pole_climber')
    pointed = RobotGeometry(ring_a_anchors=geom.ring_a_anchors, ring_b_anchors=np.zeros((6, 3)))
    with pytest.raises(ValueError, match='singular'):
        holding_forces(pointed, pointed.home_position, pointed.home_quaternion_xyzw)


def test_a_locked_universal_joint_raises():
    """Legs along the universal joints' fixed axes: the links' rotation is undefined."""
    geom = load_robot('pole_climber')
    a = geom.ring_a_anchors
    tangent = np.cross([0.0, 0.0, 1.0], a)           # neutral axes horizontal: x1 is vertical
    locked = RobotGeometry(ring_a_anchors=a, ring_b_anchors=a, ring_a_joint_axes=tangent,
                           home_position=[0.0, 0.0, 0.4])
    with pytest.raises(ValueError, match='universal joint is locked'):
        holding_forces(locked, locked.home_position, locked.home_quaternion_xyzw)


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(ROBOTS), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
       st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_closed_form_static_load_equals_the_reduced_models(name, dx, dy, dz, rx, ry, rz):
    """static_load (closed form) = generalized_forces at rest of the reduced model."""
    robot = load_robot(name)
    position = robot.home_position + 0.03 * np.array([dx, dy, dz])
    quaternion = rotation_vector_to_quat_xyzw(0.1 * np.array([rx, ry, rz]))
    pose = PlatformPose(robot, position, quaternion)
    zero = np.zeros((1, 6))
    np.testing.assert_allclose(static_load(robot, pose.ik, pose.support),
                               generalized_forces(pose, zero, zero),
                               rtol=1e-10, atol=1e-10)
