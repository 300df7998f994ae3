"""Multibody model on 91 coordinates (paper section 2.2): constraints, Jacobian, Newton DK."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import (
    euler_parameters_to_matrix,
    matrix_to_euler_parameters,
    quat_xyzw_to_matrix,
    rotation_angle_between,
    rotation_vector_to_matrix,
    rotation_vector_to_quat_xyzw,
)
from rrps_kinematics import forward_kinematics, inverse_kinematics
from rrps_kinematics.multibody import (
    N_CONSTRAINTS,
    N_COORDINATES,
    N_DRIVING,
    N_JOINT_CONSTRAINTS,
    MultibodyModel,
    body_slice,
    lower_link_body,
    structured_solve,
    upper_link_body,
)

GEOM = load_robot('pole_climber')
MODEL = MultibodyModel(GEOM)


def pose(dp=(0.0, 0.0, 0.0), rv=(0.0, 0.0, 0.0)):
    return GEOM.home_position + np.asarray(dp), rotation_vector_to_quat_xyzw(np.asarray(rv))


POSE = pose((0.012, -0.021, 0.034), (0.03, -0.05, 0.08))


def assembled():
    position, quat = POSE
    return MODEL.coordinates_from_pose(position, quat), inverse_kinematics(GEOM, *POSE).lengths


def rotate_body(q, b, R, about):
    """Rigid rotation R (global) of body b about the point `about`."""
    q = q.copy()
    s = body_slice(b)
    r, p = q[s][:3], q[s][3:]
    q[s.start:s.start + 3] = about + R @ (r - about)
    q[s.start + 3:s.stop] = matrix_to_euler_parameters(R @ euler_parameters_to_matrix(p))
    return q


def rows(phi, k):
    return phi[12 * k:12 * k + 12]


def test_sizes_and_counts():
    q, L = assembled()
    assert q.shape == (N_COORDINATES,) == (91,)
    assert (N_JOINT_CONSTRAINTS, N_DRIVING, N_CONSTRAINTS) == (72, 6, 91)
    assert MODEL.constraints(q, L).shape == (91,)
    J = MODEL.jacobian(q)
    assert J.shape == (91, 91)
    assert np.linalg.matrix_rank(J) == 91          # 72 + 6 + 13 independent constraints
    assert MODEL.jacobian_nonzeros < 0.1 * 91 * 91  # per-leg sparsity


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(-0.04, 0.04), min_size=3, max_size=3),
       st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3))
def test_assembled_coordinates_satisfy_every_constraint_and_give_back_the_pose(dp, rv):
    position, quat = pose(dp, rv)
    q = MODEL.coordinates_from_pose(position, quat)
    L = inverse_kinematics(GEOM, position, quat).lengths
    assert np.max(np.abs(MODEL.constraints(q, L))) < 1e-14
    p2, q2 = MODEL.pose_from_coordinates(q)
    np.testing.assert_allclose(p2, position, atol=1e-14)
    assert rotation_angle_between(quat_xyzw_to_matrix(q2), quat_xyzw_to_matrix(quat)) < 1e-12
    np.testing.assert_allclose(MODEL.lengths(q), L, atol=1e-14)


def test_spherical_constraint_eq3():
    q, L = assembled()
    k = 2
    # Moving the upper link by δ opens the spherical joint by exactly δ (rows 0-2).
    q1 = q.copy()
    delta = np.array([1e-3, -2e-3, 0.5e-3])
    q1[7 * upper_link_body(k):7 * upper_link_body(k) + 3] += delta
    phi = MODEL.constraints(q1, L)
    np.testing.assert_allclose(rows(phi, k)[0:3], delta, atol=1e-15)
    np.testing.assert_allclose(rows(phi, k)[3:7], 0.0, atol=1e-15)    # universal untouched
    # Rotating ring_b about the spherical joint centre keeps the joint closed.
    Rb = quat_xyzw_to_matrix(POSE[1])
    centre = POSE[0] + Rb @ GEOM.ring_b_anchors[k]
    q2 = rotate_body(q, 0, rotation_vector_to_matrix(np.array([0.2, -0.1, 0.3])), centre)
    assert np.max(np.abs(rows(MODEL.constraints(q2, L), k)[0:3])) < 1e-14


def test_universal_constraint_eqs4_5():
    q, L = assembled()
    k = 4
    lower = lower_link_body(k)
    a = GEOM.ring_a_anchors[k]
    # Rotation about the U-joint's axis fixed in ring_a: allowed, rows 3-6 stay zero.
    axis = MODEL.joints.ha[k]
    q1 = rotate_body(q, lower, rotation_vector_to_matrix(0.2 * axis), a)
    assert np.max(np.abs(rows(MODEL.constraints(q1, L), k)[3:7])) < 1e-14
    # Spin about the link's own axis through the U centre: the centre stays (eq. 4),
    # the dot-1 constraint of the two cross axes (eq. 5) breaks by sin(angle) (h · x_link).
    Rl = euler_parameters_to_matrix(q[body_slice(lower)][3:])
    q2 = rotate_body(q, lower, rotation_vector_to_matrix(0.1 * Rl[:, 2]), a)
    phi = rows(MODEL.constraints(q2, L), k)
    assert np.max(np.abs(phi[3:6])) < 1e-14
    assert abs(abs(phi[6]) - np.sin(0.1) * abs(axis @ Rl[:, 0])) < 1e-12
    assert abs(phi[6]) > 0.05
    # Translating the lower link by δ moves the U centre by δ.
    q3 = q.copy()
    q3[7 * lower:7 * lower + 3] += [0, 1e-3, 0]
    np.testing.assert_allclose(rows(MODEL.constraints(q3, L), k)[3:6], [0, 1e-3, 0], atol=1e-15)


def test_translational_constraint_eqs6_8_and_driving_eq10():
    q, L = assembled()
    k = 1
    upper = upper_link_body(k)
    s = slice(7 * upper, 7 * upper + 3)
    Rl = euler_parameters_to_matrix(q[body_slice(lower_link_body(k))][3:])
    f, g, h = Rl[:, 0], Rl[:, 1], Rl[:, 2]
    # Sliding along the leg: the prismatic joint allows it, the driving constraint measures it.
    q1 = q.copy()
    q1[s] += 0.01 * h
    phi = MODEL.constraints(q1, L)
    np.testing.assert_allclose(rows(phi, k)[7:12], 0.0, atol=1e-15)
    assert phi[72 + k] == pytest.approx(0.01, abs=1e-15)
    # Sideways offset breaks eq. 7 only.
    q2 = q.copy()
    q2[s] += 1e-3 * f
    phi = rows(MODEL.constraints(q2, L), k)
    np.testing.assert_allclose(phi[9:11], [1e-3, 0.0], atol=1e-15)
    np.testing.assert_allclose(phi[[7, 8, 11]], 0.0, atol=1e-15)
    # Spin of the upper link about the common axis breaks eq. 8 only.
    centre = q[s]
    q3 = rotate_body(q, upper, rotation_vector_to_matrix(0.05 * h), centre)
    phi = rows(MODEL.constraints(q3, L), k)
    assert abs(abs(phi[11]) - np.sin(0.05)) < 1e-12
    np.testing.assert_allclose(phi[7:11], 0.0, atol=1e-14)
    # Tilt of the upper link about g breaks eq. 6's first row.
    q4 = rotate_body(q, upper, rotation_vector_to_matrix(0.05 * g), centre)
    phi = rows(MODEL.constraints(q4, L), k)
    assert abs(abs(phi[7]) - np.sin(0.05)) < 1e-12
    assert abs(phi[8]) < 1e-14


def test_normalisation_constraint_eq9():
    q, L = assembled()
    q1 = q.copy()
    q1[7 * 5 + 3:7 * 5 + 7] *= 1.01
    phi = MODEL.constraints(q1, L)
    assert phi[78 + 5] == pytest.approx(1.01**2 - 1.0, rel=1e-12)
    assert np.count_nonzero(np.abs(phi[78:]) > 1e-15) == 1


@pytest.mark.parametrize('seed', [0, 1])
def test_analytic_jacobian_matches_finite_differences(seed):
    q, L = assembled()
    rng = np.random.default_rng(seed)
    q = q + 0.02 * rng.normal(size=91)            # off the constraint manifold too
    J = MODEL.jacobian(q)
    h = 1e-6
    Jfd = np.empty((91, 91))
    for i in range(91):
        e = np.zeros(91)
        e[i] = h
        Jfd[:, i] = (MODEL.constraints(q + e, L) - MODEL.constraints(q - e, L)) / (2 * h)
    np.testing.assert_allclose(J, Jfd, atol=1e-8)
    np.testing.assert_array_equal(MODEL.jacobian(q, sparse=True).toarray(), J)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-0.03, 0.03), min_size=3, max_size=3),
       st.lists(st.floats(-0.1, 0.1), min_size=3, max_size=3),
       st.sampled_from(['structured', 'sparse', 'dense']))
def test_direct_kinematics_agrees_with_pose_level_fk(dp, rv, solver):
    seed_position, seed_quat = POSE
    position, quat = pose(np.asarray(dp) + (POSE[0] - GEOM.home_position), rv)
    L = inverse_kinematics(GEOM, position, quat).lengths
    q_seed = MODEL.coordinates_from_pose(seed_position, seed_quat)
    dk = MODEL.direct_kinematics(L, q_seed, solver=solver)
    fk = forward_kinematics(GEOM, L, seed_position, seed_quat)
    assert dk.converged and fk.converged
    assert dk.residual <= 1e-12
    assert np.max(np.abs(dk.position - fk.position)) < 1e-9
    angle = rotation_angle_between(quat_xyzw_to_matrix(dk.quaternion_xyzw),
                                   quat_xyzw_to_matrix(fk.quaternion_xyzw))
    assert angle < 1e-9
    assert 1 <= dk.iterations <= 8
    assert dk.flops > 0 and dk.seconds > 0


def test_direct_kinematics_counts_work_and_reports_non_convergence():
    q, L = assembled()
    far = MODEL.coordinates_from_pose(*pose((0.0, 0.0, -0.05), (0.0, 0.0, 0.3)))
    one = MODEL.direct_kinematics(L, far, max_iterations=1)
    assert not one.converged and one.iterations == 1 and one.residual > 1e-6
    full = MODEL.direct_kinematics(L, far)
    assert full.converged and full.iterations > 1
    assert full.flops > one.flops
    at_solution = MODEL.direct_kinematics(L, q)
    assert at_solution.converged and at_solution.iterations == 0
    dense = MODEL.direct_kinematics(L, far, solver='dense')
    sparse = MODEL.direct_kinematics(L, far, solver='sparse')
    assert dense.iterations == sparse.iterations == full.iterations
    np.testing.assert_allclose(sparse.q, full.q, atol=1e-14)
    np.testing.assert_allclose(dense.q, full.q, atol=1e-14)
    # A dense LU costs 2/3 n^3 per iteration; the structured and sparse solves far less.
    assert dense.flops > (2 * 91**3 // 3) * dense.iterations > max(full.flops, sparse.flops)


def test_structured_solve_equals_a_dense_solve():
    q, L = assembled()
    rng = np.random.default_rng(3)
    q = q + 0.01 * rng.normal(size=91)
    J = MODEL.jacobian(q)
    rhs = rng.normal(size=91)
    ok, dq, flops = structured_solve(J, rhs)
    assert ok and 0 < flops < 30_000
    np.testing.assert_allclose(dq, np.linalg.solve(J, rhs), rtol=1e-9, atol=1e-12)
    J[:, 7 * 3:7 * 5] = 0.0                               # leg 1's links lose their columns
    assert not structured_solve(J, rhs)[0]


def test_bad_input_raises_value_error():
    q, L = assembled()
    with pytest.raises(ValueError, match='shape'):
        MODEL.constraints(q[:90], L)
    with pytest.raises(ValueError, match='NaN'):
        MODEL.jacobian(np.full(91, np.nan))
    with pytest.raises(ValueError, match='lengths'):
        MODEL.direct_kinematics(L[:5], q)
    with pytest.raises(ValueError, match='solver'):
        MODEL.direct_kinematics(L, q, solver='qr')
    with pytest.raises(ValueError):
        MODEL.coordinates_from_pose([0, 0, np.inf], [0, 0, 0, 1])
