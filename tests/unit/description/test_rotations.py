"""rrps_description.rotations: quaternions, Euler parameters, 3-1-3 angles, exp/log maps."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from rrps_description.rotations import (
    cross,
    euler313_to_matrix,
    euler_parameters_to_matrix,
    euler_parameters_to_quat_xyzw,
    matrix_to_euler313,
    matrix_to_euler_parameters,
    matrix_to_quat_xyzw,
    normalize_quat,
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    quat_xyzw_to_euler_parameters,
    quat_xyzw_to_matrix,
    quat_xyzw_to_rotation_vector,
    rotation_angle_between,
    rotation_vector_to_matrix,
    rotation_vector_to_quat_xyzw,
    skew,
)

SETTINGS = settings(max_examples=60, deadline=None)

quaternions = arrays(np.float64, 4, elements=st.floats(-1, 1, allow_nan=False)).filter(
    lambda q: np.linalg.norm(q) > 1e-3).map(lambda q: q / np.linalg.norm(q))
angles = st.floats(-np.pi, np.pi, allow_nan=False)


def _is_rotation(R):
    return np.allclose(R @ R.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(R), 1.0)


@SETTINGS
@given(quaternions)
def test_quaternion_matrix_matches_scipy_and_paper_formula(q):
    R = quat_xyzw_to_matrix(q)
    assert _is_rotation(R)
    np.testing.assert_allclose(R, Rotation.from_quat(q).as_matrix(), atol=1e-12)
    # The paper's A = (2 e0^2 - 1) I + 2 (e e^T + e0 e~) with (e0, e) = (w, x, y, z).
    np.testing.assert_allclose(R, euler_parameters_to_matrix(quat_xyzw_to_euler_parameters(q)),
                               atol=1e-12)


@SETTINGS
@given(quaternions)
def test_q_and_minus_q_are_the_same_rotation(q):
    np.testing.assert_allclose(quat_xyzw_to_matrix(q), quat_xyzw_to_matrix(-q), atol=1e-15)
    back = matrix_to_quat_xyzw(quat_xyzw_to_matrix(-q))
    assert back[3] >= 0.0
    np.testing.assert_allclose(np.abs(back @ q), 1.0, atol=1e-12)
    np.testing.assert_allclose(normalize_quat(-q), normalize_quat(q), atol=1e-15)
    np.testing.assert_allclose(matrix_to_quat_xyzw(quat_xyzw_to_matrix(-q)),
                               matrix_to_quat_xyzw(quat_xyzw_to_matrix(q)), atol=1e-15)


@pytest.mark.parametrize('q', [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 0], [0.6, -0.8, 0, 0]])
def test_half_turn_quaternions_have_one_canonical_sign(q):
    q = np.array(q, dtype=float)
    a, b = normalize_quat(q), normalize_quat(-q)
    np.testing.assert_array_equal(a, b)
    assert a[np.flatnonzero(a)[0]] > 0


@SETTINGS
@given(quaternions)
def test_matrix_to_quaternion_round_trip(q):
    R = quat_xyzw_to_matrix(q)
    np.testing.assert_allclose(quat_xyzw_to_matrix(matrix_to_quat_xyzw(R)), R, atol=1e-12)
    p = matrix_to_euler_parameters(R)
    assert p[0] >= 0.0
    np.testing.assert_allclose(euler_parameters_to_quat_xyzw(p), matrix_to_quat_xyzw(R), atol=1e-15)


@pytest.mark.parametrize('axis', range(3))
def test_half_turns_use_the_robust_branches(axis):
    v = np.zeros(3)
    v[axis] = np.pi
    R = rotation_vector_to_matrix(v)
    q = matrix_to_quat_xyzw(R)
    np.testing.assert_allclose(np.abs(q[axis]), 1.0, atol=1e-12)
    np.testing.assert_allclose(quat_xyzw_to_matrix(q), R, atol=1e-12)


@SETTINGS
@given(angles, st.floats(0.0, np.pi, allow_nan=False), angles)
def test_euler313_matches_scipy_and_round_trips(psi, alpha, phi):
    R = euler313_to_matrix([psi, alpha, phi])
    np.testing.assert_allclose(R, Rotation.from_euler('ZXZ', [psi, alpha, phi]).as_matrix(), atol=1e-12)
    ang = matrix_to_euler313(R)
    assert 0.0 <= ang[1] <= np.pi
    np.testing.assert_allclose(euler313_to_matrix(ang), R, atol=1e-9)
    if 1e-6 < alpha < np.pi - 1e-6:
        # Away from gimbal lock the angles themselves come back (mod 2 pi).
        np.testing.assert_allclose(np.angle(np.exp(1j * (ang - [psi, alpha, phi]))), 0.0, atol=1e-7)


@pytest.mark.parametrize('alpha', [0.0, np.pi, 1e-13, np.pi - 1e-13])
@pytest.mark.parametrize('psi,phi', [(0.3, 0.4), (-2.0, 1.5), (3.0, 3.0)])
def test_euler313_gimbal_lock(alpha, psi, phi):
    R = euler313_to_matrix([psi, alpha, phi])
    ang = matrix_to_euler313(R)
    assert ang[2] == 0.0 and ang[1] in (0.0, np.pi)
    np.testing.assert_allclose(euler313_to_matrix(ang), R, atol=1e-12)
    # Only psi + phi (alpha = 0) or psi - phi (alpha = pi) is defined.
    expected = psi + phi if ang[1] == 0.0 else psi - phi
    assert np.angle(np.exp(1j * (ang[0] - expected))) == pytest.approx(0.0, abs=1e-9)


@SETTINGS
@given(quaternions, quaternions)
def test_quaternion_product_composes_rotations(q1, q2):
    np.testing.assert_allclose(quat_xyzw_to_matrix(quat_multiply_xyzw(q1, q2)),
                               quat_xyzw_to_matrix(q1) @ quat_xyzw_to_matrix(q2), atol=1e-12)
    ident = quat_multiply_xyzw(q1, quat_conjugate_xyzw(q1))
    np.testing.assert_allclose(np.abs(ident), [0, 0, 0, 1], atol=1e-12)


@SETTINGS
@given(arrays(np.float64, 3, elements=st.floats(-3.0, 3.0, allow_nan=False)).filter(
    lambda v: np.linalg.norm(v) < np.pi - 1e-6))
def test_rotation_vector_exp_log(v):
    R = rotation_vector_to_matrix(v)
    np.testing.assert_allclose(R, Rotation.from_rotvec(v).as_matrix(), atol=1e-12)
    back = quat_xyzw_to_rotation_vector(rotation_vector_to_quat_xyzw(v))
    np.testing.assert_allclose(back, v, atol=1e-9)
    assert rotation_angle_between(np.eye(3), R) == pytest.approx(np.linalg.norm(v), abs=1e-9)


def test_small_rotation_vectors_are_accurate():
    for v in ([1e-9, 0, 0], [0, 2e-7, -1e-7], [0.0, 0.0, 0.0]):
        v = np.array(v)
        np.testing.assert_allclose(rotation_vector_to_matrix(v), Rotation.from_rotvec(v).as_matrix(),
                                   atol=1e-15)
        np.testing.assert_allclose(quat_xyzw_to_rotation_vector(rotation_vector_to_quat_xyzw(v)), v,
                                   atol=1e-18)


def test_batches_keep_leading_shape():
    rng = np.random.default_rng(1)
    q = rng.normal(size=(4, 5, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    R = quat_xyzw_to_matrix(q)
    assert R.shape == (4, 5, 3, 3)
    assert matrix_to_quat_xyzw(R).shape == (4, 5, 4)
    assert matrix_to_euler313(R).shape == (4, 5, 3)
    for k in range(4):
        for j in range(5):
            np.testing.assert_allclose(R[k, j], quat_xyzw_to_matrix(q[k, j]), atol=1e-15)


def test_skew_is_the_cross_product():
    a, b = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.7, -1.1])
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b))
    np.testing.assert_allclose(skew(a), -skew(a).T)


def test_cross_matches_numpy_with_broadcasting():
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=(4, 6, 3)), rng.normal(size=(6, 3))
    np.testing.assert_allclose(cross(a, b), np.cross(a, b), atol=1e-15)
    np.testing.assert_allclose(cross(a[0, 0], [0.0, 0.0, 1.0]), np.cross(a[0, 0], [0.0, 0.0, 1.0]))
