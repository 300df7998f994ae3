"""The driver's jerk-limited setpoints follow a command stream as its stamps time it: legs that
follow one stream move as one, however the transport delivers it (late, bunched, after a stall)."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_hardware.setpoints import DRIVER_PERIOD, JerkLimitedSetpoints

LIMITS = load_robot('pole_climber').motion_limits.legs
PERIOD = 0.02                    # the climb node's stream
DISTANCE, DURATION = 0.1, 4.0    # a cosine rest-to-rest move, 0.039 m/s at its peak
SCALE = 1.0 + np.array([0.0, 2.0, 4.0, -2.0, -4.0, 1.0]) * 1e-4   # six legs along one stream, each its own share
OFFSET = np.array([0.0, 10.0, -10.0, 5.0, -5.0, 3.0]) * 1e-6      # of it, from its own length
START = 0.4


def profile(t):
    """The stream's common motion [m] at path time ``t`` [s]: D (1 - cos(pi t / T)) / 2."""
    return 0.5 * DISTANCE * (1.0 - np.cos(np.pi * np.clip(t, 0.0, DURATION) / DURATION))


def stream(*, jitter: bool, stall: bool, seed: int = 1) -> list[tuple[float, float, np.ndarray]]:
    """(arrival, stamp, lengths) of each command; ``jitter``: each delivered up to 15 ms late
    (two may come together); ``stall``: none sent for 0.3 s, then the path resumes 0.2 s behind
    (a climb node's stalled tick advances its path by at most five periods)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(int((DURATION + 0.2) / PERIOD) + 1):
        t = k * PERIOD
        if stall and 1.0 < t < 1.3:
            continue
        path = t - 0.2 if stall and t >= 1.0 else t
        arrival = t + 1e-4 + (rng.uniform(0.0, 0.015) if jitter else 0.0)
        out.append((arrival, t, START + OFFSET + SCALE * profile(path)))
    return out


def drive(commands, *, stamped: bool = True) -> np.ndarray:
    """The setpoints every driver period, each new command taken at the first period after it
    arrived (as driver_node takes the newest one), with its stamp or without."""
    gen = JerkLimitedSetpoints(LIMITS, START + OFFSET)
    out, i, seen = [], 0, -1
    for n in range(int((DURATION + 2.0) / DRIVER_PERIOD)):
        now = n * DRIVER_PERIOD
        while i < len(commands) and commands[i][0] <= now:
            i += 1
        if i - 1 > seen:
            arrival, stamp, lengths = commands[i - 1]
            gen.command(lengths, now, stamp if stamped else None)
            seen = i - 1
        out.append(gen.step(now, DRIVER_PERIOD))
    return np.array(out)


def common_motion_spread(setpoints: np.ndarray) -> float:
    """The largest difference [m] between the legs' motions, each mapped back to the common one."""
    return float(np.ptp((setpoints - START - OFFSET) / SCALE, axis=1).max())


def test_the_stream_profile_is_within_the_legs_limits():
    t = np.linspace(0.0, DURATION, 3001)
    v = 0.5 * DISTANCE * np.pi / DURATION * np.sin(np.pi * t / DURATION) * SCALE.max()
    assert v.max() < LIMITS.speed
    assert 0.5 * DISTANCE * (np.pi / DURATION) ** 2 * SCALE.max() < LIMITS.acceleration


@pytest.mark.parametrize('jitter, stall, apart', [(False, False, 5e-5), (True, False, 5e-5), (False, True, 2.5e-4),
                                                   (True, True, 2.5e-4)])
def test_legs_that_follow_one_stream_move_as_one(jitter, stall, apart):
    setpoints = drive(stream(jitter=jitter, stall=stall))
    # mapped back to the common motion, legs that follow the stream stay within their lags'
    # differences (their shares differ by up to 8e-4); a stalled stream's stop, each leg's
    # time-optimal stop synchronised in time, parts them by up to 0.2 mm. A leg that parted from
    # the others as the transport's timing went (a stream timed by its arrivals) is mm off.
    assert common_motion_spread(setpoints) < apart
    np.testing.assert_allclose(setpoints[-1], START + OFFSET + SCALE * profile(DURATION), rtol=0, atol=1e-9)
    steps = np.diff(setpoints, axis=0) / DRIVER_PERIOD
    assert np.abs(steps).max() <= LIMITS.speed + 1e-9


def test_a_stream_delivered_late_is_followed_as_its_stamps_time_it():
    on_time = drive(stream(jitter=False, stall=False))
    late = drive(stream(jitter=True, stall=False))
    # a command up to 15 ms late only holds the setpoints' target until it comes: they stay
    # within what the stream moves in that time (40 mm/s x 15 ms = 0.6 mm)
    assert np.abs(late - on_time).max() < 6e-4
    # without stamps, the arrivals time the stream: bunched commands read as speed jumps
    unstamped = drive(stream(jitter=True, stall=True), stamped=False)
    assert common_motion_spread(unstamped) > 1e-3


def test_a_stream_that_stops_is_not_overshot():
    """A minimum-jerk rest-to-rest stream, s = D (10 x^3 - 15 x^4 + 6 x^5), x = t / T: its peaks
    1.875 D / T, 5.77 D / T^2 and 60 D / T^3 (by hand) within the legs' limits, its braking at
    half the acceleration limit. The setpoints keep its acceleration into the stop: they come to
    rest on its end, never a tenth of a millimetre past it."""
    d, T = 0.008, 0.6
    assert 1.875 * d / T < LIMITS.speed and 5.77 * d / T ** 2 < LIMITS.acceleration and 60 * d / T ** 3 < LIMITS.jerk
    x = np.clip(np.arange(0.0, T + 0.5, PERIOD) / T, 0.0, 1.0)
    lengths = START + d * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5)
    commands = [(k * PERIOD + 1e-4, k * PERIOD, np.full(6, L)) for k, L in enumerate(lengths)]
    gen = JerkLimitedSetpoints(LIMITS, np.full(6, START))
    setpoints = []
    for n in range(int((T + 1.5) / DRIVER_PERIOD)):
        now = n * DRIVER_PERIOD
        arrived = [c for c in commands if c[0] <= now]
        if arrived and (n == 0 or arrived[-1][0] > now - DRIVER_PERIOD):
            gen.command(arrived[-1][2], now, arrived[-1][1])
        setpoints.append(gen.step(now, DRIVER_PERIOD))
    setpoints = np.array(setpoints)
    assert setpoints.max() - (START + d) < 1e-4
    np.testing.assert_allclose(setpoints[-1], START + d, rtol=0, atol=1e-9)


def test_legs_with_different_shares_regain_speed_after_a_stall_along_the_streams_path():
    """Six legs whose shares of one stream differ (as a pose's legs do: one lengthens near full
    speed while another barely moves): after a stall the stream resumes at its speed and the legs
    regain their velocities in phase, their wanted velocities scaled as a whole within the speed
    limit, so the setpoints return to the stream's path, the line START + shares * s (by hand: the
    distance of each setpoint from that line). Each leg clipped and accelerating on its own left
    the line by 6 mm. (The stop into the stall, time-synchronised, leaves it by up to 1.4 mm here.)"""
    shares = np.array([1.0, 0.6, 0.25, -0.35, -0.8, 0.05])
    rng = np.random.default_rng(3)
    commands = []
    for k in range(int((DURATION + 0.6) / PERIOD) + 1):   # the path to its end (0.4 s behind)
        t = k * PERIOD
        if 1.0 < t < 1.5:   # silent long enough for the setpoints to stop on the last command
            continue
        path = t - 0.4 if t >= 1.0 else t   # resumed 0.1 s of path on (a stalled tick's five periods)
        commands.append((t + 1e-4 + rng.uniform(0.0, 0.002), t, START + shares * profile(path)))
    gen = JerkLimitedSetpoints(LIMITS, np.full(6, START))
    out, i = [], 0
    for n in range(int((DURATION + 2.5) / DRIVER_PERIOD)):
        now = n * DRIVER_PERIOD
        fresh = None
        while i < len(commands) and commands[i][0] <= now:
            fresh, i = commands[i], i + 1
        if fresh is not None:
            gen.command(fresh[2], now, fresh[1])
        out.append(gen.step(now, DRIVER_PERIOD))
    offsets = np.array(out) - START
    unit = shares / np.linalg.norm(shares)
    off_path = np.linalg.norm(offsets - np.outer(offsets @ unit, unit), axis=1)
    resumed = int(1.5 / DRIVER_PERIOD)
    assert off_path[:int(1.0 / DRIVER_PERIOD)].max() < 1e-5        # on the path before the stall
    assert off_path[resumed:].max() < 5e-4, off_path[resumed:].max()
    assert off_path[int(3.0 / DRIVER_PERIOD):].max() < 1e-4        # and back on it
    np.testing.assert_allclose(out[-1], START + shares * profile(DURATION), rtol=0, atol=1e-9)
