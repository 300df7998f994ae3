"""InputWatch (what a climbing step watches) and PhasePath (a timed motion phase as a stream
plays it, and its sample nearest a pose)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_climbing.climb_watch import InputWatch
from rrps_climbing.phase_path import PhasePath
from rrps_description.pose import Pose, pose_error
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_interfaces.climb import PauseReason


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def _watch():
    clock = Clock()
    return clock, InputWatch(state_timeout=0.2, operator_timeout=0.5, clock=clock)


def _tick(clock, watch, dt=0.02, busy=0.0):
    clock.t += dt
    watch.tick_started()
    clock.t += busy
    watch.tick_ended()


def test_fresh_inputs_let_a_step_go_and_stale_ones_hold_it():
    clock, watch = _watch()
    assert watch.hold_reason(driver_active=True) is PauseReason.ROBOT_STATE_LOST  # never received
    watch.received('pose')
    watch.received('grippers/state')
    assert watch.hold_reason(driver_active=True) is None
    assert watch.hold_reason(driver_active=False) is PauseReason.DRIVER_INACTIVE
    assert not watch.operator_seen()
    watch.received('teleop/status')
    for _ in range(15):  # 0.3 s of regular ticks, the robot's state keeps coming
        _tick(clock, watch)
        watch.received('pose')
        watch.received('grippers/state')
    assert watch.judged()
    assert watch.hold_reason(driver_active=True) is None  # the operator was heard 0.3 s ago
    for _ in range(15):  # 0.3 s without the robot's state
        _tick(clock, watch)
    assert watch.hold_reason(driver_active=True) is PauseReason.ROBOT_STATE_LOST
    assert 'pose 0.30 s old, grippers/state 0.30 s old' in watch.ages()


def test_the_operator_link_is_lost_after_operator_timeout_only():
    clock, watch = _watch()
    watch.received('teleop/status')
    for k in range(40):  # 0.8 s of regular ticks with the robot's state
        _tick(clock, watch)
        watch.received('pose')
        watch.received('grippers/state')
        expected = PauseReason.OPERATOR_LINK_LOST if 0.02 * (k + 1) > 0.5 + 1e-9 else None
        assert watch.hold_reason(driver_active=True) is expected, k
    assert 'teleop/status 0.80 s old' in watch.ages()


def test_ages_are_judged_only_after_a_state_timeout_without_a_stall_of_the_node():
    clock, watch = _watch()
    watch.received('pose')
    watch.received('grippers/state')
    _tick(clock, watch)
    assert watch.judged()
    _tick(clock, watch, busy=0.3)  # a tick that planned for 0.3 s: inputs may be queued
    assert not watch.judged()
    assert watch.hold_reason(driver_active=True) is PauseReason.ROBOT_STATE_LOST  # the raw verdict
    for _ in range(4):  # regular ticks for 0.2 s after the stall
        assert not watch.judged()
        _tick(clock, watch, dt=0.05)
    clock.t += 0.01
    assert watch.judged()
    _tick(clock, watch, dt=0.25)  # a late tick is a stall too
    assert not watch.judged()
    with pytest.raises(ValueError, match='unknown input'):
        watch.received('actuators/state')


def _samples(n=5):
    times = np.linspace(0.0, 2.0, n)
    positions = np.linspace([0, 0, 0.4], [0.0, 0.0, 0.46], n)
    quaternions = np.array([rotation_vector_to_quat_xyzw(np.array([0, 0, 0.1 * k / n])) for k in range(n)])
    return times, positions, quaternions, np.column_stack([np.linspace(0, 0.2, n), np.zeros(n)])


def test_a_phase_path_gives_its_samples_at_their_times_and_holds_the_last():
    times, positions, quaternions, angles = _samples()
    timed = PhasePath(times, positions, quaternions, angles)
    assert timed.duration == 2.0
    start, a0 = timed.at(0.0)
    assert pose_error(start, Pose(positions[0], quaternions[0])) == pytest.approx((0.0, 0.0), abs=1e-12)
    end, a1 = timed.at(timed.duration + 1.0)
    assert pose_error(end, Pose(positions[-1], quaternions[-1])) == pytest.approx((0.0, 0.0), abs=1e-12)
    np.testing.assert_allclose(a1, angles[-1])
    middle, am = timed.at(times[2])
    assert pose_error(middle, Pose(positions[2], quaternions[2]))[0] < 1e-12
    np.testing.assert_allclose(am, angles[2], atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(st.floats(0.0, 1.0))
def test_a_phase_path_moves_linearly_between_its_samples(fraction):
    times, positions, quaternions, angles = _samples()
    timed = PhasePath(times, positions, quaternions, angles)
    pose, _ = timed.at(fraction * timed.duration)
    assert pose.position[2] == pytest.approx(0.4 + 0.06 * fraction, abs=1e-12)


def test_a_phase_path_rejects_bad_shapes_and_times():
    times, positions, quaternions, angles = _samples()
    with pytest.raises(ValueError, match='positions'):
        PhasePath(times, positions[:, :2], quaternions, angles)
    with pytest.raises(ValueError, match='ring_angles'):
        PhasePath(times, positions, quaternions, angles[:, :1])
    with pytest.raises(ValueError, match='times'):
        PhasePath(times[::-1], positions, quaternions, angles)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3), st.floats(-0.2, 0.2), st.floats(0.0, 2.5))
def test_the_nearest_sample_played_is_the_one_a_pose_by_pose_search_finds(offset, turn, until):
    """PhasePath.nearest against a search sample by sample with pose_error (1 mm ~ 0.01 rad)."""
    times, positions, quaternions, angles = _samples(40)
    timed = PhasePath(times, positions, quaternions, angles)
    pose = Pose(positions[20] + offset, rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, turn])))
    scores = [e[0] / 1e-3 + e[1] / 1e-2 for e in (pose_error(pose, Pose(p, q)) for p, q in zip(positions, quaternions))]
    played = int(np.searchsorted(times, until, side='right')) or 1
    best = min(range(played), key=lambda k: scores[k])
    t = timed.nearest(pose, until, 1e-3, 1e-2)
    assert t <= max(until, 0.0) or t == 0.0
    assert scores[int(np.flatnonzero(times == t)[0])] == pytest.approx(scores[best], rel=1e-9, abs=1e-9)
