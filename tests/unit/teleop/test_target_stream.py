"""Teleop's jerk-limited target stream (rrps_teleop.target_stream): the streamed poses' leg lengths
(eq. 1 written here: |p + R b_i - a_i|) checked by finite differences against the legs' speed,
acceleration and jerk limits; the stop against the bang-bang stop derived by hand.

A third finite difference of samples h apart is an average of the third derivative over 3h (a
B-spline weighting), so a motion with |jerk| <= J has |third differences| / h^3 <= J; likewise for
the speed and the acceleration. Only the kinematics' rounding (1e-12 m) is added as tolerance.
"""

import math

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.motion_limits import STREAM_RATE_SHARE, STREAM_SPEED_SHARE
from rrps_teleop.mapping import TeleopConfig, TeleopMapping
from rrps_teleop.target_stream import TargetStream, stopping_distance, stopping_time
from rrps_testing.virtual_work import quaternion_matrix

SLAVE = load_robot('pole_climber')
H = 0.01
LIMITS = SLAVE.motion_limits.legs


def leg_lengths(position, quaternion) -> np.ndarray:
    """Eq. 1: the distance from each ring_a anchor to its ring_b anchor placed by the pose."""
    b = np.asarray(position) + np.asarray(SLAVE.ring_b_anchors) @ quaternion_matrix(quaternion).T
    return np.linalg.norm(b - np.asarray(SLAVE.ring_a_anchors), axis=1)


def differences(lengths: np.ndarray, h: float = H) -> tuple[float, float, float]:
    """The largest |speed|, |acceleration|, |jerk| of samples h apart, by finite differences."""
    d = [np.diff(lengths, n=k, axis=0) / h ** k for k in (1, 2, 3)]
    return tuple(float(np.abs(x).max()) for x in d)


def command(offset) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A command: the home pose shifted by ``offset`` [m], its lengths."""
    p = np.asarray(SLAVE.home_position) + np.asarray(offset, dtype=float)
    q = np.asarray(SLAVE.home_quaternion_xyzw, dtype=float)
    return leg_lengths(p, q), p, q


def within(lengths, tolerance=1e-5) -> None:
    """Within the stream's limits, to Ruckig's precision (``tolerance``, relative: its profiles'
    phase times are solved numerically; a jerk at the limit measured 1.1e-6 over)."""
    v, a, j = differences(np.asarray(lengths))
    assert v <= STREAM_SPEED_SHARE * LIMITS.speed * (1.0 + tolerance), v
    assert a <= STREAM_RATE_SHARE * LIMITS.acceleration * (1.0 + tolerance), a
    assert j <= STREAM_RATE_SHARE * LIMITS.jerk * (1.0 + tolerance), j


def test_a_jump_of_the_command_is_streamed_within_the_legs_limits_and_reached_exactly():
    stream = TargetStream(SLAVE)
    start, goal = command((0.0, 0.0, 0.0)), command((0.004, -0.002, 0.02))
    first = stream.follow(0.0, *start)
    np.testing.assert_array_equal(first[1], start[1])   # from rest on the command itself: no jump
    samples = [first] + [stream.follow(k * H, *goal) for k in range(1, 400)]
    lengths = np.array([leg_lengths(p, q) for _, p, q in samples])
    np.testing.assert_allclose(lengths, [s[0] for s in samples], atol=1e-9)   # the pose is the lengths' FK
    within(lengths)
    assert np.array_equal(samples[-1][1], goal[1]) and not stream.moving   # arrived exactly, at rest
    # no overshoot: each leg moves monotonically from its start to its goal length
    steps = np.diff(lengths, axis=0) * np.sign(goal[0] - start[0])
    assert steps.min() > -1e-12


def test_a_moving_command_is_followed_within_the_limits_and_a_held_one_is_reached_without_overshoot():
    stream = TargetStream(SLAVE)
    samples = []
    for k in range(300):   # the command moves 20 mm/s along z for 1.5 s, then holds (a guard's halt)
        c = command((0.0, 0.0, 0.02 * min(k, 150) * H))
        samples.append(stream.follow(k * H, *c))
    lengths = np.array([s[0] for s in samples])
    within(lengths)
    held = command((0.0, 0.0, 0.02 * 150 * H))[0]
    over = (lengths - held) * np.sign(held - lengths[0])
    assert over.max() < 1e-9, over.max()   # never past the held command
    np.testing.assert_array_equal(lengths[-1], held)


def hand_stop(v: float) -> float:
    """The bang-bang stop's time from speed v at zero acceleration under a and j (derived by hand):
    jerk -j until the acceleration is -a, cruise at -a, jerk +j to rest; when v < a^2/j the
    acceleration never reaches -a: jerk -j for sqrt(v/j), then +j for as long."""
    a, j = STREAM_RATE_SHARE * LIMITS.acceleration, STREAM_RATE_SHARE * LIMITS.jerk
    if v <= a * a / j:
        return 2.0 * math.sqrt(v / j)
    return 2.0 * a / j + (v - a * a / j) / a


def stop_after(stream: TargetStream, k: int) -> list:
    """The stream's stop from step ``k`` on, until it rests."""
    stops = []
    while (sample := stream.stop((k + len(stops) + 1) * H)) is not None:
        stops.append(sample)
    return stops


def test_a_stop_from_full_speed_is_the_fastest_jerk_limited_one():
    """Cruise at the legs' speed towards a far command, then stop: at rest within the hand-derived
    stopping time (plus a sample), no farther than its distance, braking from the first sample on."""
    stream = TargetStream(SLAVE)
    stream.follow(0.0, *command((0.0, 0.0, 0.0)))
    far = command((0.0, 0.0, 0.08))
    samples = [stream.follow(k * H, *far) for k in range(1, 60)]
    v0 = float(np.abs(stream.velocity).max())
    assert v0 == pytest.approx(STREAM_SPEED_SHARE * LIMITS.speed) and np.abs(stream.acceleration).max() < 1e-9
    t_stop = stopping_time(v0, stream.limits)
    assert t_stop == pytest.approx(hand_stop(v0), rel=1e-12)
    stops = stop_after(stream, 59)
    within(np.array([s[0] for s in samples + stops]))
    assert len(stops) * H <= t_stop + H + 1e-9, (len(stops) * H, t_stop)
    travelled = float(np.abs(stops[-1][0] - samples[-1][0]).max())
    assert travelled <= stopping_distance(v0, stream.limits) + 1e-9
    assert stopping_distance(v0, stream.limits) == pytest.approx(v0 * t_stop / 2.0)
    assert float(np.abs(stops[0][0] - samples[-1][0]).max()) / H < v0   # braking at once


def test_a_stop_from_a_slow_follow_rests_within_the_stopping_time_of_its_speed():
    """Following a command that moves 4 mm/s (teleop speeds), then stopped: at rest within the
    hand-derived stopping time of its speed and the time to shed its acceleration, under 0.1 s."""
    stream = TargetStream(SLAVE)
    samples = [stream.follow(k * H, *command((0.0, 0.0, 0.004 * k * H))) for k in range(200)]
    v0 = float(np.abs(stream.velocity).max())
    a0 = float(np.abs(stream.acceleration).max())
    j = STREAM_RATE_SHARE * LIMITS.jerk
    stops = stop_after(stream, 199)
    within(np.array([s[0] for s in samples + stops]))
    bound = hand_stop(v0 + a0 * a0 / (2.0 * j)) + a0 / j
    assert len(stops) * H <= bound + H + 1e-9, (len(stops) * H, bound)
    assert len(stops) * H < 0.1


def test_the_mapping_s_commands_streamed_stay_within_the_limits_through_engage_motion_and_release():
    """A guarded mapping (the pole climber, 100 Hz master) engaged from rest, moved by a master
    jumping 10 mm, released: the stream it gives starts and stops without a velocity jump."""
    mapping = TeleopMapping(SLAVE, TeleopConfig(max_linear_speed=0.05))
    stream = TargetStream(SLAVE)
    p0, q0 = np.asarray(SLAVE.home_position, float), np.asarray(SLAVE.home_quaternion_xyzw, float)
    m0 = np.zeros(3)
    mapping.on_slave_pose(p0, q0)
    out_lengths = []
    for k in range(200):
        t = k * H
        mapping.on_enable(t, k < 120)
        mapping.on_master_pose(t, m0 + (0.0025 if k >= 10 else 0.0) * np.array([0.0, 0.0, 1.0]), [0, 0, 0, 1.0])
        out = mapping.step(t)
        sample = stream.follow(t, out.lengths, out.position, out.quaternion_xyzw) if out.has_command \
            else stream.stop(t)
        if sample is not None:
            out_lengths.append(leg_lengths(sample[1], sample[2]))
    lengths = np.array(out_lengths)
    within(lengths)
    assert not stream.moving
    assert np.abs(lengths[-1] - lengths[0]).max() > 1e-3   # it did move
