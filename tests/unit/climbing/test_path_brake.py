"""A paused stream's brake along its path (rrps_climbing.path_brake, PlayClock.brake) against a
numerical integration of its rate, the limits it is timed within, and the driver's jerk-limited
setpoints (the legs): braked, they stop at the stream's last target; stopped at speed, they overshoot it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_climbing.path_brake import brake_time, braked_path_time
from rrps_climbing.phase_path import PlayClock
from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_hardware.setpoints import stream_setpoints
from rrps_testing.paused_stream import paused_stream

LIMITS = ActuatorLimits(speed=0.05, acceleration=0.25, jerk=2.5)   # the pole climber's legs
PERIOD = 0.02


def _rate(tau, duration):
    """1 - the quintic smootherstep, written out here."""
    x = np.clip(np.asarray(tau) / duration, 0.0, 1.0)
    return 1.0 - (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5)


def test_the_path_time_is_the_integral_of_the_falling_rate_and_ends_half_the_brake_on():
    duration = 0.4
    tau = np.linspace(0.0, 0.6, 6001)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (_rate(tau[1:], duration) + _rate(tau[:-1], duration))
                                                * np.diff(tau))])
    ours = np.array([braked_path_time(t, duration) for t in tau])
    np.testing.assert_allclose(ours, integral, atol=1e-9)
    assert braked_path_time(10.0, duration) == pytest.approx(duration / 2)
    assert braked_path_time(-1.0, duration) == 0.0


def test_the_brake_keeps_a_leg_at_the_stream_speed_within_the_stream_acceleration_and_jerk():
    stream = stream_limits(LIMITS)
    duration = brake_time(stream)
    tau = np.linspace(0.0, duration, 20001)
    speed = stream.speed * _rate(tau, duration)
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
        assert overshoot < 0.2e-3
    else:
        # by hand: the shortest jerk-limited stop from v at rest, v / a + a / j, runs v t / 2 on
        v, a, j = stream_limits(LIMITS).speed, LIMITS.acceleration, LIMITS.jerk
        assert overshoot > 0.8 * v * (v / a + a / j) / 2 > 5e-3
    assert abs(setpoints[-1] - commands[-1, 0]) < 1e-6


def test_a_clock_brakes_from_its_last_tick_and_a_restart_ends_the_brake():
    clock = PlayClock(PERIOD)
    clock.brake(0.4)
    assert not clock.braking                      # no tick yet: nothing to brake
    for k in range(5):
        clock.advance(k * PERIOD)
    t0 = clock.t
    clock.brake(0.4)
    assert clock.braking
    times = []
    while clock.braking:                          # ticks on from the last one, at 4 PERIOD
        times.append(clock.advance((5 + len(times)) * PERIOD))
    assert times[-1] == pytest.approx(t0 + 0.2)
    assert np.all(np.diff(np.diff(times)) < 0)     # slower each tick
    assert clock.advance(10.0) == pytest.approx(t0 + 0.2)   # at rest after it
    clock.restart()
    assert clock.advance(11.0) == pytest.approx(t0 + 0.2 + PERIOD) and not clock.braking
