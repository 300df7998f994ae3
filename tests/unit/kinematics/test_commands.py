"""Target validation (rrps_kinematics.commands): the IK and margins of a target, rejections that
say why, joint-space velocity limits, the compiled check against the reference, and the warm-up
of the IK node's compiled guard for the argument types its targets have.

ik_node calls ``pose_limits`` with the robot's home pose at start-up so that the first target
does not wait for numba to compile. A robot's home quaternion is a read-only array, a target's
is writable: numba types them differently, so ``pose_limits`` must hand the kernel the same
array type whatever it gets.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics, margins
from rrps_kinematics.backend import use_numba
from rrps_kinematics.commands import InvalidTarget, limit_velocity, pose_limits, validate_target
from rrps_testing.ci import require
from rrps_testing.reference_limits import reference_margins


@pytest.fixture(scope='module')
def robot():
    return load_robot('pole_climber')


def test_valid_target_gives_the_ik_lengths_and_normalises_a_nearly_unit_quaternion(robot):
    p = robot.home_position + [0.01, 0.0, 0.02]
    q = np.array([0.0, 0.0, 0.0, 1.0 + 5e-4])
    t = validate_target(robot, p, q, frame_id='ring_a')
    np.testing.assert_allclose(t.lengths, inverse_kinematics(robot, p, [0, 0, 0, 1]).lengths, atol=1e-15)
    assert np.linalg.norm(t.quaternion_xyzw) == pytest.approx(1.0, abs=1e-15)
    assert all(v >= 0 for v in t.minimum.values())


@pytest.mark.parametrize('position, quaternion, frame, message', [
    ([0.0, 0.0, 0.42], [0, 0, 0, 1], 'world', "frame_id is 'world'"),
    ([0.0, np.nan, 0.42], [0, 0, 0, 1], 'ring_a', 'NaN'),
    ([0.0, 0.0, 0.42], [0, 0, 0, np.inf], 'ring_a', 'NaN'),
    ([0.0, 0.0], [0, 0, 0, 1], 'ring_a', 'shape|position'),
    ([0.0, 0.0, 0.42], [0, 0, 0, 1.1], 'ring_a', 'quaternion norm'),
    ([0.0, 0.0, 0.42], [0, 0, 0, 0], 'ring_a', 'quaternion norm'),
    ([0.0, 0.0, 0.9], [0, 0, 0, 1], 'ring_a', 'stroke'),
])
def test_rejections_say_why(robot, position, quaternion, frame, message):
    with pytest.raises(InvalidTarget, match=message):
        validate_target(robot, position, quaternion, frame_id=frame)


@settings(max_examples=60, deadline=None)
@given(current=st.lists(st.floats(0.3, 0.55), min_size=6, max_size=6),
       desired=st.lists(st.floats(0.3, 0.55), min_size=6, max_size=6),
       dt=st.floats(0.0, 0.1))
def test_limit_velocity_keeps_the_direction_and_the_speed(current, desired, dt):
    c, d = np.array(current), np.array(desired)
    out = limit_velocity(c, d, 0.05, dt)
    step = out - c
    assert np.max(np.abs(step)) <= 0.05 * dt + 1e-15
    if np.max(np.abs(d - c)) <= 0.05 * dt:
        np.testing.assert_array_equal(out, d)
    else:  # a positive multiple of the requested step
        k = np.dot(step, d - c) / np.dot(d - c, d - c)
        np.testing.assert_allclose(step, k * (d - c), atol=1e-15)
        assert 0.0 <= k < 1.0


def test_limit_velocity_unlimited_and_invalid():
    np.testing.assert_array_equal(limit_velocity(np.zeros(6), np.ones(6), math.inf, 0.0), np.ones(6))
    with pytest.raises(ValueError):
        limit_velocity(np.zeros(6), np.ones(6), 0.0, 0.1)


@settings(max_examples=150, deadline=None)
@given(dp=st.lists(st.floats(-0.2, 0.2), min_size=3, max_size=3),
       rv=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3))
def test_compiled_pose_limits_match_the_reference_margins(robot, dp, rv):
    p = robot.home_position + np.array(dp)
    q = rotation_vector_to_quat_xyzw(np.array(rv))
    ok, lengths, minimum = pose_limits(robot, p, q)
    m = margins(robot, inverse_kinematics(robot, p, q))
    assert ok == m.ok
    np.testing.assert_allclose(lengths, m.lengths, rtol=0, atol=1e-14)
    for kind, value in m.minimum.items():
        assert minimum[kind] == pytest.approx(float(value), abs=1e-12), kind
    assert pose_limits(robot, p, q, backend='numpy')[0] == ok
    ref = reference_margins(robot, p, q)       # independent: arccos, KKT, SVD
    np.testing.assert_allclose(lengths, ref['lengths'], rtol=0, atol=1e-12)
    for kind in ('stroke', 'interference'):
        assert minimum[kind] == pytest.approx(float(np.min(ref[kind])), abs=1e-12), kind
    for kind in ('universal', 'spherical'):
        assert minimum[kind] == pytest.approx(float(np.min(ref[kind])), abs=1e-7), kind
    assert minimum['conditioning'] == pytest.approx(ref['conditioning'], rel=1e-9, abs=1e-12)


def test_the_warm_up_compiles_the_signature_targets_use():
    require(use_numba('auto'), 'numba is not in use')
    from rrps_kinematics.compiled_limits import pose_margins
    g = load_robot('pole_climber')
    assert not g.home_quaternion_xyzw.flags.writeable  # the case this guards against
    pose_limits(g, g.home_position, g.home_quaternion_xyzw)       # ik_node's warm-up
    compiled = len(pose_margins.signatures)
    readonly = np.array([0.0, 0.0, 0.42])
    readonly.flags.writeable = False
    for p, q in (([0.0, 0.0, 0.42], [0.0, 0.0, 0.0, 1.0]),                  # lists
                 (np.array([0.0, 0.0, 0.42]), np.array([0.0, 0.0, 0.0, 1.0])),  # a target's arrays
                 (readonly, g.home_quaternion_xyzw)):
        validate_target(g, p, q, frame_id='ring_a')
        assert len(pose_margins.signatures) == compiled, 'a new compilation at the first target'
