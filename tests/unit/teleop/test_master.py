"""The simulated master robot (rrps_teleop.master): scripted trajectories and the operator's handle."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_angle_between
from rrps_kinematics import check_pose, inverse_kinematics
from rrps_teleop.master import HandleMotion, MasterModel, scripted_pose

MASTER = load_robot('master_robot')
HOME_P, HOME_Q = MASTER.home_position, MASTER.home_quaternion_xyzw


def scripted(kind, t, **kw):
    args = dict(amplitude=0.005, period=10.0, angular_amplitude=0.05) | kw
    return scripted_pose(kind, t, HOME_P, HOME_Q, **args)


def test_none_is_the_home_pose():
    for t in (0.0, 1.3, 100.0):
        p, q = scripted('none', t)
        np.testing.assert_array_equal(p, HOME_P)
        np.testing.assert_array_equal(q, HOME_Q)


def test_circle_has_the_amplitude_as_radius_and_the_period():
    ts = np.linspace(0.0, 10.0, 41)
    ps = np.array([scripted('circle', t)[0] for t in ts])
    np.testing.assert_allclose(np.linalg.norm(ps - HOME_P, axis=1), 0.005, atol=1e-12)
    np.testing.assert_allclose(ps[:, 2], HOME_P[2], atol=1e-15)
    np.testing.assert_allclose(ps[0], ps[-1], atol=1e-12)
    np.testing.assert_allclose(ps[10] - HOME_P, [0.0, 0.005, 0.0], atol=1e-12)  # a quarter period


def test_lissajous_starts_at_home_is_periodic_and_rotates_within_its_amplitude():
    p, q = scripted('lissajous', 0.0)
    np.testing.assert_allclose(p, HOME_P, atol=1e-15)
    assert rotation_angle_between(HOME_Q, q) < 1e-12
    p10, q10 = scripted('lissajous', 10.0)
    np.testing.assert_allclose(p10, HOME_P, atol=1e-12)
    angles = [rotation_angle_between(HOME_Q, scripted('lissajous', t)[1]) for t in np.linspace(0, 10, 101)]
    assert 0.02 < max(angles) <= 0.05 * math.sqrt(2.25) + 1e-12
    offsets = np.array([scripted('lissajous', t)[0] - HOME_P for t in np.linspace(0, 10, 101)])
    assert np.all(np.abs(offsets) <= 0.005 + 1e-12) and np.abs(offsets[:, 2]).max() <= 0.0025 + 1e-12


@pytest.mark.parametrize('kwargs, match', [
    (dict(kind='square'), 'trajectory must be one of'),
    (dict(period=0.0), 'period must be finite and > 0'),
    (dict(period=math.nan), 'period must be finite and > 0'),
    (dict(amplitude=-0.01), 'amplitude must be finite and >= 0'),
    (dict(angular_amplitude=math.inf), 'angular_amplitude must be finite'),
])
def test_scripted_pose_rejects_bad_parameters(kwargs, match):
    kind = kwargs.pop('kind', 'circle')
    with pytest.raises(ValueError, match=match):
        scripted(kind, 1.0, **kwargs)


def test_the_master_starts_at_home_and_its_encoders_give_the_ik_lengths():
    m = MasterModel(MASTER)
    np.testing.assert_allclose(m.position, HOME_P)
    np.testing.assert_allclose(m.lengths, MASTER.home_lengths, atol=1e-12)


def test_a_reachable_target_is_reached_at_the_speed_limit():
    m = MasterModel(MASTER, max_linear_speed=0.05, max_angular_speed=1.0)
    target = HOME_P + [0.004, -0.003, 0.002]
    note = m.move_toward(target, HOME_Q, 0.05)  # 2.5 mm allowed, 5.4 mm asked
    assert note.motion is HandleMotion.SPEED_LIMITED and str(note) == 'speed limited'
    np.testing.assert_allclose(np.linalg.norm(m.position - HOME_P), 0.0025, rtol=1e-9)
    for _ in range(3):
        m.move_toward(target, HOME_Q, 0.05)
    np.testing.assert_allclose(m.position, target, atol=1e-15)
    assert m.move_toward(target, HOME_Q, 0.05).motion is HandleMotion.FULL
    np.testing.assert_allclose(m.lengths, inverse_kinematics(MASTER, target, HOME_Q).lengths)


def test_the_scripted_trajectory_is_tracked_exactly_within_the_speed_limit():
    m = MasterModel(MASTER)
    for k in range(1, 200):
        p, q = scripted('lissajous', 0.01 * k)
        assert m.move_toward(p, q, 0.01).motion is HandleMotion.FULL
        np.testing.assert_allclose(m.position, p, atol=1e-15)
        assert rotation_angle_between(m.quaternion_xyzw, q) < 1e-9


def test_an_unreachable_target_stops_the_handle_on_its_limits():
    m = MasterModel(MASTER)
    target = HOME_P + [0.0, 0.0, 0.1]  # far beyond the 0.1375 m stroke
    note = m.move_toward(target, HOME_Q, 10.0)
    assert note.motion is HandleMotion.STOPPED
    assert str(note).startswith('stopped at the limits: stroke: leg_1')
    ok, _, margins = check_pose(MASTER, m.position, m.quaternion_xyzw)
    assert ok and 0.0 <= margins.minimum['stroke'] < 1e-4
    beyond = m.position + [0.0, 0.0, 1e-3]
    assert not check_pose(MASTER, beyond, m.quaternion_xyzw)[0]


@pytest.mark.parametrize('position, quaternion, match', [
    ([0.0, math.nan, 0.1], [0, 0, 0, 1], 'NaN or infinite'),
    ([0.0, 0.0, 0.1], [0, 0, 0, 2], 'quaternion norm'),
    ([0.0, 0.0], [0, 0, 0, 1], 'shape'),
])
def test_malformed_targets_raise_and_leave_the_master_where_it_was(position, quaternion, match):
    m = MasterModel(MASTER)
    with pytest.raises(ValueError, match=match):
        m.move_toward(position, quaternion, 0.01)
    np.testing.assert_array_equal(m.position, HOME_P)


def test_bad_speeds_are_refused():
    with pytest.raises(ValueError, match='max_linear_speed'):
        MasterModel(MASTER, max_linear_speed=0.0)
    with pytest.raises(ValueError, match='dt must be finite'):
        MasterModel(MASTER).move_toward(HOME_P, HOME_Q, -1.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.08, 0.08), st.floats(-0.08, 0.08), st.floats(-0.08, 0.08),
                          st.floats(-0.8, 0.8), st.floats(-0.8, 0.8), st.floats(-0.8, 0.8)),
                min_size=1, max_size=4))
def test_property_the_master_never_leaves_its_limits(targets):
    from rrps_description.rotations import quat_multiply_xyzw, rotation_vector_to_quat_xyzw
    m = MasterModel(MASTER, max_linear_speed=1.0, max_angular_speed=10.0)
    for x, y, z, rx, ry, rz in targets:
        q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.array([rx, ry, rz])), HOME_Q)
        before = m.position.copy()
        m.move_toward(HOME_P + [x, y, z], q, 0.05)
        assert check_pose(MASTER, m.position, m.quaternion_xyzw)[0]
        assert np.linalg.norm(m.position - before) <= 0.05 + 1e-12
