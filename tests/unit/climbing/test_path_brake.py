"""A paused stream's brake along its path (rrps_climbing.path_brake, PlayClock.brake) against the
time-optimal jerk-limited stop derived by hand, a numerical integration of its rate, the limits it is
timed within, and the driver's jerk-limited setpoints (the legs): braked, they stop at the stream's
last target; stopped at speed, they overshoot it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_climbing.path_brake import PathBrake, brake_time
from rrps_climbing.phase_path import PlayClock
from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_hardware.setpoints import stream_setpoints
from rrps_testing.paused_stream import paused_stream

LIMITS = ActuatorLimits(speed=0.05, acceleration=0.25, jerk=2.5)   # the pole climber's legs
PERIOD = 0.02


def _hand_rate(tau, A, J):
    """The path rate of the shortest stop from 1 at rest in acceleration, |r'| <= A, |r''| <= J, by hand:
    jerk -J for t1, (constant deceleration A for t2), jerk +J for t1."""
    t1 = min(A / J, math.sqrt(1.0 / J))
    peak = J * t1
    t2 = max(1.0 / peak - t1, 0.0)
    tau = np.asarray(tau, dtype=float)
    rise = 1.0 - J * np.minimum(tau, t1) ** 2 / 2
    cruise = 1.0 - J * t1 ** 2 / 2 - peak * np.clip(tau - t1, 0.0, t2)
    late = np.clip(tau - t1 - t2, 0.0, t1)
    rate = np.where(tau <= t1, rise, np.where(tau <= t1 + t2, cruise, cruise - peak * late + J * late ** 2 / 2))
    return np.clip(rate, 0.0, 1.0), 2 * t1 + t2


@pytest.mark.parametrize('limits', [LIMITS, ActuatorLimits(speed=0.05, acceleration=0.25, jerk=0.5),
                                    ActuatorLimits(speed=0.02, acceleration=1.0, jerk=2.0)],
                         ids=['pole', 'jerk-bound', 'short'])
def test_the_brake_is_the_hand_derived_shortest_stop_and_the_path_time_its_integral(limits):
    brake = PathBrake(limits)
    A, J = limits.acceleration / limits.speed, limits.jerk / limits.speed
    tau = np.linspace(0.0, 1.5 * brake.duration, 6001)
    rate, duration = _hand_rate(tau, A, J)
    assert brake.duration == pytest.approx(duration, rel=1e-9)
    assert brake_time(limits) == brake.duration
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(tau))])
    np.testing.assert_allclose([brake.path_time(t) for t in tau], integral, atol=1e-6)
    assert brake.path_time(10.0) == pytest.approx(duration / 2)   # point-symmetric: half the brake on
    assert brake.path_time(-1.0) == 0.0


def test_the_brake_keeps_a_leg_at_the_stream_speed_within_the_stream_acceleration_and_jerk():
    stream = stream_limits(LIMITS)
    brake = PathBrake(stream)
    tau = np.linspace(0.0, brake.duration, 20001)
    speed = stream.speed * np.gradient([brake.path_time(t) for t in tau], tau)
    acceleration = np.gradient(speed, tau)
    jerk = np.gradient(acceleration, tau)
    assert np.max(np.abs(acceleration)) <= stream.acceleration * (1 + 1e-3)
    assert np.max(np.abs(jerk)) <= stream.jerk * (1 + 1e-2)
    # the shortest such brake: one of the two limits is reached
    assert max(np.max(np.abs(acceleration)) / stream.acceleration, np.max(np.abs(jerk)) / stream.jerk) > 0.98


@pytest.mark.parametrize('braked', [False, True])
def test_braked_the_legs_stop_at_the_last_target_stopped_at_speed_they_overshoot_it(braked):
    commands = paused_stream(LIMITS, PERIOD, braked=braked)
    setpoints = stream_setpoints(commands, PERIOD, LIMITS, settle=3.0)[:, 0]
    overshoot = np.max(setpoints) - commands[-1, 0]
    if braked:
        stream = stream_limits(LIMITS)
        # the brake ran half its duration at the stream speed on: that far past the point of the pause
        assert commands[-1, 0] - commands[-2 - math.ceil(brake_time(stream) / PERIOD), 0] == pytest.approx(
            stream.speed * (PERIOD + brake_time(stream) / 2), rel=0.05)
        # the setpoints' lag behind a brake at the stream limits: 0.65 mm, against 7 mm stopped at speed
        assert overshoot < 1e-3
    else:
        # by hand: the shortest jerk-limited stop from v at rest, v / a + a / j, runs v t / 2 on
        v, a, j = stream_limits(LIMITS).speed, LIMITS.acceleration, LIMITS.jerk
        assert overshoot > 0.8 * v * (v / a + a / j) / 2 > 5e-3
    assert abs(setpoints[-1] - commands[-1, 0]) < 1e-6


def test_a_clock_brakes_from_its_last_tick_and_a_restart_ends_the_brake():
    clock = PlayClock(PERIOD)
    brake = PathBrake(ActuatorLimits(speed=0.05, acceleration=0.25, jerk=2.5))
    clock.brake(brake)
    assert not clock.braking                      # no tick yet: nothing to brake
    for k in range(5):
        clock.advance(k * PERIOD)
    t0 = clock.t
    clock.brake(brake)
    assert clock.braking
    times = []
    while clock.braking:                          # ticks on from the last one, at 4 PERIOD
        times.append(clock.advance((5 + len(times)) * PERIOD))
    assert times[-1] == pytest.approx(t0 + brake.duration / 2)
    assert np.all(np.diff(np.diff(times)) < 0)     # slower each tick
    assert clock.advance(10.0) == pytest.approx(t0 + brake.duration / 2)   # at rest after it
    clock.restart()
    assert clock.advance(11.0) == pytest.approx(t0 + brake.duration / 2 + PERIOD) and not clock.braking
