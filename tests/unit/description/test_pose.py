"""The one pose type and validation policy (rrps_description.pose)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.pose import QUATERNION_TOLERANCE, InvalidPose, Pose, pose_error, validate_pose
from rrps_description.rotations import (
    normalize_quat,
    quat_xyzw_to_matrix,
    rotation_angle_between,
    rotation_vector_to_quat_xyzw,
)

vectors = st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3).map(np.array)
rotvecs = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)
poses = st.builds(lambda p, r: Pose(p, rotation_vector_to_quat_xyzw(r)), vectors, rotvecs)


@pytest.mark.parametrize('position, quaternion, message', [
    ([0.0, np.nan, 0.0], [0, 0, 0, 1], 'NaN'),
    ([0.0, 0.0, 0.0], [0, 0, np.inf, 1], 'NaN'),
    ([0.0, 0.0], [0, 0, 0, 1], 'shape'),
    ([0.0, 0.0, 0.0], [0, 0, 1], 'shape'),
    ([0.0, 0.0, 0.0], [0, 0, 0, 1.1], 'quaternion norm'),
    ([0.0, 0.0, 0.0], [0, 0, 0, 0], 'quaternion norm'),
    (['a', 0.0, 0.0], [0, 0, 0, 1], 'numbers'),
])
def test_the_policy_refuses_malformed_poses_and_says_why(position, quaternion, message):
    with pytest.raises(InvalidPose, match=message):
        validate_pose(position, quaternion, what='target')
    assert issubclass(InvalidPose, ValueError)


def test_a_nearly_unit_quaternion_is_normalised_and_a_raw_one_only_on_request():
    p, q = validate_pose([0, 0, 1], [0, 0, 0, 1 + 0.5 * QUATERNION_TOLERANCE])
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
    with pytest.raises(InvalidPose):
        validate_pose([0, 0, 1], [0, 0, 0, 3.0])
    assert np.allclose(validate_pose([0, 0, 1], [0, 0, 0, 3.0], tolerance=None)[1], [0, 0, 0, 1])


@settings(max_examples=200, deadline=None)
@given(rotvecs)
def test_q_and_minus_q_validate_to_one_canonical_quaternion(r):
    q = rotation_vector_to_quat_xyzw(r)
    a, b = validate_pose(np.zeros(3), q)[1], validate_pose(np.zeros(3), -q)[1]
    assert np.array_equal(a, b)
    np.testing.assert_allclose(a, normalize_quat(q), atol=1e-15)


@settings(max_examples=100, deadline=None)
@given(poses, poses, vectors)
def test_composition_and_inverse_agree_with_matrices(a, b, point):
    np.testing.assert_allclose((a @ b).matrix, a.matrix @ b.matrix, atol=1e-12)
    np.testing.assert_allclose((a @ a.inverse()).matrix, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(a.apply(point), a.matrix[:3, :3] @ point + a.matrix[:3, 3], atol=1e-12)
    assert Pose.from_matrix(a.matrix) == a or pose_error(Pose.from_matrix(a.matrix), a)[1] < 1e-7


@settings(max_examples=200, deadline=None)
@given(rotvecs, st.floats(0.0, math.pi))
def test_rotation_angle_is_the_angle_of_the_relative_rotation(r, angle):
    axis = r / np.linalg.norm(r) if np.linalg.norm(r) > 1e-6 else np.array([0.0, 0.0, 1.0])
    q0 = rotation_vector_to_quat_xyzw(r)
    q1 = normalize_quat(quat_multiply(rotation_vector_to_quat_xyzw(angle * axis), q0))
    assert rotation_angle_between(q0, q1) == pytest.approx(angle, abs=1e-7)
    R = quat_xyzw_to_matrix(q1) @ quat_xyzw_to_matrix(q0).T
    assert math.acos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)) == pytest.approx(angle, abs=1e-6)


def quat_multiply(a, b):
    from rrps_description.rotations import quat_multiply_xyzw
    return quat_multiply_xyzw(a, b)


def test_pose_is_immutable_and_hashable():
    a = Pose([1.0, 2.0, 3.0])
    with pytest.raises(AttributeError):
        a.position = np.zeros(3)
    with pytest.raises(ValueError):
        a.position[0] = 5.0
    assert len({a, Pose([1.0, 2.0, 3.0])}) == 1
    assert np.allclose(Pose(np.zeros(3), [0.0, 0.0, 1.0, 0.0]).wxyz, [0.0, 0.0, 0.0, 1.0])
