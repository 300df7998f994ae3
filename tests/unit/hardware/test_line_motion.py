"""Legs in phase: a motion along one line of the legs' space keeps every leg on that line, the
leading leg at its own limits; its stop time checked against the jerk-limited stop written out by
hand."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.motion_limits import ActuatorLimits
from rrps_hardware.line_motion import LineMotion, phase_line

LIMITS = ActuatorLimits(speed=0.05, acceleration=0.25, jerk=2.5)
DT = 0.002
SHARES = np.array([1.0, 0.6, 0.25, -0.35, -0.8, 0.05])
U = SHARES / np.linalg.norm(SHARES)


def test_the_line_of_legs_in_phase_and_of_legs_out_of_it():
    v, a = 0.04 * U, -0.1 * U
    np.testing.assert_allclose(phase_line(v, a), U)
    np.testing.assert_allclose(phase_line(np.zeros(6), a), -U)
    assert phase_line(np.zeros(6), np.zeros(6)) is None
    across = np.array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0]) * 1e-3
    assert phase_line(v, a + across) is None
    np.testing.assert_allclose(phase_line(v, a + across, shed=2e-3), U)   # within one period's jerk


def test_a_brake_along_the_line_keeps_the_legs_in_phase_and_takes_the_hand_computed_time():
    """From the leading leg at 0.05 m/s (its share 1/|shares| of the line's speed): a stop at the
    jerk limit j with the acceleration limit a reached (v >= a^2 / j) takes v / a + a / j."""
    motion = LineMotion(LIMITS)
    lead = U[0]
    p, v, a = np.full(6, 0.4), LIMITS.speed / lead * U, np.zeros(6)
    states, t, finished = [], 0.0, False
    while not finished:
        p, v, a, finished = motion.step(p, v, a, U, DT, target_velocity=0.0)
        states.append((p, v, a))
        t += DT
    assert t == pytest.approx(LIMITS.speed / LIMITS.acceleration + LIMITS.acceleration / LIMITS.jerk, abs=2 * DT)
    positions = np.array([s[0] for s in states]) - 0.4
    ratios = positions / SHARES
    np.testing.assert_allclose(ratios, ratios[:, :1] * np.ones(6), rtol=1e-9, atol=1e-15)   # on the line
    accelerations = np.array([s[2] for s in states])
    assert np.abs(accelerations[:, 0]).max() == pytest.approx(LIMITS.acceleration, rel=1e-6)
    assert np.abs(np.diff(accelerations, axis=0)).max() / DT <= LIMITS.jerk * (1 + 1e-9)
    # the stop's length, by hand: v t_total / 2 for the symmetric trapezoid of the acceleration
    assert positions[-1, 0] == pytest.approx(LIMITS.speed * t / 2, rel=0.02)


def test_an_acceleration_across_the_line_is_shed_within_the_jerk_limit():
    motion = LineMotion(LIMITS)
    across = np.array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0]) * 0.4 * LIMITS.jerk * DT
    p, v, a, _ = motion.step(np.zeros(6), 0.03 * U, -0.2 * U + across, U, DT, target_velocity=0.0)
    assert np.abs(a - (-0.2 * U + across)).max() / DT <= LIMITS.jerk * (1 + 1e-9)
    np.testing.assert_allclose(a / U, (a / U)[0])   # on the line again
