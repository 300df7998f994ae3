"""base_link's odometry (rrps_kinematics.base_odometry) against independent computations: its FK
covariance against a Monte Carlo of the Newton FK of noisy leg lengths, its pose covariance
while ring_b grips against a Monte Carlo of the odometry's own chaining (world_T_b frozen from one
noisy FK, base_link through another), its growth over hand-overs, and its twist against a motion
of known velocity."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.rotations import quat_xyzw_to_rotation_vector, rotation_vector_to_quat_xyzw
from rrps_kinematics import forward_kinematics
from rrps_kinematics.base_odometry import BaseOdometry, fk_covariance

G = load_robot('pole_climber')
A_T_B = Pose([0.006, -0.004, 0.43], rotation_vector_to_quat_xyzw([0.02, -0.03, 0.05]))
SIGMA = 2e-5
N = 4000


def _noisy_fk(rng, a_T_b: Pose) -> list[Pose]:
    """FK (Newton, rrps_kinematics.forward) of a_T_b's leg lengths with N(0, SIGMA²) noise."""
    from rrps_kinematics import leg_lengths
    lengths = np.asarray(leg_lengths(G, a_T_b.position, a_T_b.quaternion_xyzw))
    noisy = lengths + rng.normal(0.0, SIGMA, (N, 6))
    result = forward_kinematics(G, noisy, a_T_b.position, a_T_b.quaternion_xyzw)
    assert np.all(result.converged)
    return [Pose(p, q) for p, q in zip(result.position, result.quaternion_xyzw)]


def _coordinates(poses: list[Pose], nominal: Pose) -> np.ndarray:
    """(position - nominal's, rotation vector of R R_nominalᵀ): errors about the fixed axes."""
    return np.array([np.concatenate([T.position - nominal.position,
                                     quat_xyzw_to_rotation_vector((T @ nominal.inverse()).quaternion_xyzw)])
                     for T in poses])


def _close(empirical: np.ndarray, model: np.ndarray) -> None:
    """Standard deviations within 10 % (N = 4000 samples: ~1 %), correlations within 0.1."""
    s_e, s_m = np.sqrt(np.diag(empirical)), np.sqrt(np.diag(model))
    np.testing.assert_allclose(s_e, s_m, rtol=0.1)
    np.testing.assert_allclose(empirical / np.outer(s_e, s_e), model / np.outer(s_m, s_m), atol=0.1)


def test_fk_covariance_is_the_spread_of_fk_of_noisy_lengths():
    samples = _noisy_fk(np.random.default_rng(1), A_T_B)
    errors = np.array([np.concatenate([T.position - A_T_B.position,
                                       quat_xyzw_to_rotation_vector((A_T_B.inverse() @ T).quaternion_xyzw)])
                       for T in samples])
    # Σ_FK's rotation coordinates are in ring_a's frame: R_b' = exp(δθ) R_b, i.e. about a's axes
    errors[:, 3:] = errors[:, 3:] @ A_T_B.rotation.T
    _close(np.cov(errors.T), fk_covariance(G, A_T_B, SIGMA))


def test_while_ring_b_grips_the_base_carries_two_fks_as_the_chaining_does():
    """ring_a opens: ring_b's world pose is frozen from one FK, base_link is ring_b's pose
    through the inverse of another: Monte Carlo of that chain, with FK of noisy lengths."""
    world_T_a = Pose([0.1, -0.2, 1.3], rotation_vector_to_quat_xyzw([0.0, 0.4, 0.1]))
    rng = np.random.default_rng(2)
    released, current = _noisy_fk(rng, A_T_B), _noisy_fk(rng, A_T_B)
    chained = [world_T_a @ b1 @ b2.inverse() for b1, b2 in zip(released, current)]
    odometry = BaseOdometry(G, SIGMA, 0.02)
    odometry.update(world_T_a, A_T_B, True, 0.0)
    estimate = odometry.update(world_T_a, A_T_B, False, 0.02)
    _close(np.cov(_coordinates(chained, world_T_a).T), estimate.pose_covariance)


def test_the_covariance_grows_by_each_hand_over_and_stands_while_ring_a_grips():
    world_T_a = Pose([0.0, 0.0, 1.0])
    odometry = BaseOdometry(G, SIGMA, 0.02)
    t = iter(np.arange(0.0, 10.0, 0.02))
    start = odometry.update(world_T_a, A_T_B, True, next(t)).pose_covariance
    assert np.all(start == 0.0)  # the odometry's origin is where it starts
    on_b = odometry.update(world_T_a, A_T_B, False, next(t)).pose_covariance
    after_one = odometry.update(world_T_a, A_T_B, True, next(t)).pose_covariance
    np.testing.assert_allclose(after_one, on_b)  # ring_a closes: the base stops with what it had
    assert np.all(np.linalg.eigvalsh(after_one) > 0.0)
    np.testing.assert_allclose(odometry.update(world_T_a, A_T_B, True, next(t)).pose_covariance, after_one)
    odometry.update(world_T_a, A_T_B, False, next(t))
    after_two = odometry.update(world_T_a, A_T_B, True, next(t)).pose_covariance
    np.testing.assert_allclose(after_two, 2.0 * after_one, rtol=1e-9)   # the same pose: twice


def test_the_twist_is_the_motion_in_base_links_frame():
    """A base turning at ω about z while moving at v (given in odom): v and ω in base_link."""
    v_odom, w = np.array([0.01, 0.02, 0.05]), np.array([0.0, 0.0, 0.2])
    dt, yaw0 = 0.01, 0.7
    poses = [Pose(v_odom * k * dt, rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, yaw0]) + w * k * dt))
             for k in range(3)]
    odometry = BaseOdometry(G, SIGMA, 0.02)
    first = odometry.update(poses[0], A_T_B, False, 0.0)
    assert np.all(first.twist == 0.0)
    estimate = odometry.update(poses[1], A_T_B, False, dt)
    c, s = np.cos(yaw0), np.sin(yaw0)
    v_base = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ v_odom  # R(yaw0)ᵀ v
    np.testing.assert_allclose(estimate.twist[:3], v_base, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(estimate.twist[3:], w, rtol=1e-9)
    np.testing.assert_allclose(estimate.twist_covariance, 2.0 * fk_covariance(G, A_T_B, SIGMA) / dt ** 2)


def test_bad_settings_are_refused():
    with pytest.raises(ValueError):
        BaseOdometry(G, -1.0, 0.02)
    with pytest.raises(ValueError):
        BaseOdometry(G, 1e-4, 0.0)
