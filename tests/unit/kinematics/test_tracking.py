"""PoseTracker: warm-started FK of a length stream, continuation for large steps, mode-jump guard."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import normalize_quat, rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.tracking import PoseTracker
from rrps_testing.virtual_work import quaternion_matrix

POLE = load_robot('pole_climber')


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.01, 0.01), st.floats(-0.01, 0.01), st.floats(-0.01, 0.01),
                          st.floats(-0.03, 0.03)), min_size=1, max_size=10))
def test_small_steps_are_tracked_exactly(steps):
    tracker = PoseTracker(POLE)
    p, r = POLE.home_position.copy(), np.zeros(3)
    for dx, dy, dz, dr in steps:
        p, r = p + [dx, dy, dz], r + dr
        q = rotation_vector_to_quat_xyzw(r)
        update = tracker.update(inverse_kinematics(POLE, p, q).lengths)
        assert update.accepted and not update.continuation
        assert tracker.distance(p, q) < 1e-9


def test_a_large_step_on_a_clear_path_is_solved_by_continuation():
    tracker = PoseTracker(POLE)
    p = [-0.2486, -0.1579, 0.5848]
    q = normalize_quat(np.array([0.1153, -0.5694, -0.0938, 0.8085]))
    update = tracker.update(inverse_kinematics(POLE, p, q).lengths)
    assert update.accepted and update.continuation
    assert tracker.distance(p, q) < 1e-9


@pytest.mark.parametrize('p, q, reason', [
    ([0.1625, -0.0235, 0.3632], [-0.2923, 0.5986, 0.4026, 0.6278], 'det(J) changed sign'),
    ([-0.1225, -0.0935, 0.5857], [0.5507, -0.4988, -0.5149, 0.4276], 'continuation path'),
    ([0.1097, 0.192, 0.3612], [0.3366, 0.4925, -0.5175, 0.6135], 'no convergence'),
])
def test_refused_updates_keep_the_last_estimate(p, q, reason):
    """Far poses (found by a random search from home) whose lengths the tracker must not follow."""
    tracker = PoseTracker(POLE)
    update = tracker.update(inverse_kinematics(POLE, p, normalize_quat(np.array(q))).lengths)
    assert not update.accepted and reason in update.reason
    np.testing.assert_array_equal(tracker.position, POLE.home_position)
    np.testing.assert_allclose(tracker.lengths, POLE.home_lengths, atol=1e-15)


def test_reset_mirror_mode_and_invalid_input():
    tracker = PoseTracker(POLE)
    mirror = POLE.home_position * [1, 1, -1]  # planar anchors: the same lengths, ring_b below ring_a
    tracker.reset(mirror, [0, 0, 0, 1])
    assert tracker.det_sign == -PoseTracker(POLE).det_sign
    assert tracker.update(POLE.home_lengths).accepted  # stays in the mirrored assembly mode
    np.testing.assert_allclose(tracker.position, mirror, atol=1e-12)
    with pytest.raises(ValueError):
        tracker.update([0.4] * 5)
    with pytest.raises(ValueError):
        tracker.update([np.nan] * 6)
    with pytest.raises(ValueError):
        PoseTracker(POLE, continuation_steps=0)


def test_jacobian_sign_backends_agree(monkeypatch):
    tracker = PoseTracker(POLE)
    rng = np.random.default_rng(5)
    poses = [(POLE.home_position + rng.uniform(-0.2, 0.2, 3), rotation_vector_to_quat_xyzw(rng.uniform(-1.5, 1.5, 3)))
             for _ in range(50)] + [(POLE.home_position * [1, 1, -1], np.array([0.0, 0.0, 0.0, 1.0]))]
    compiled = [tracker.jacobian_sign(p, q) for p, q in poses]
    monkeypatch.setattr('rrps_kinematics.tracking.use_numba', lambda backend: False)
    assert [tracker.jacobian_sign(p, q) for p, q in poses] == compiled
    assert {-1.0, 1.0} <= set(compiled)
    # independently: the sign of det J of the test's own inverse Jacobian (eq. 1)
    for (p, q), sign in zip(poses, compiled):
        R = quaternion_matrix(q)
        b = POLE.ring_b_anchors @ R.T
        legs = p + b - POLE.ring_a_anchors
        u = legs / np.linalg.norm(legs, axis=1, keepdims=True)
        assert np.sign(np.linalg.det(np.hstack([u, np.cross(b, u)]))) == sign


def test_solver_settings_are_checked_when_set():
    tracker = PoseTracker(POLE, tolerance=1e-10, max_iterations=5)
    assert (tracker.tolerance, tracker.max_iterations) == (1e-10, 5)
    tracker.max_iterations = 0
    update = tracker.update(POLE.home_lengths * 1.001)
    assert not update.accepted and update.fk.iterations == 0
    tracker.max_iterations = 30
    assert tracker.update(POLE.home_lengths * 1.001).accepted
    with pytest.raises(ValueError, match='tolerance'):
        tracker.tolerance = float('nan')
    assert tracker.tolerance == 1e-10
