"""A paused stream's stop along its path: the path's time rate falls from 1 to 0 along the quintic
smootherstep, so the legs slow down on the planned path instead of the stream stopping at speed
(which the driver's jerk-limited setpoints overshoot and come back from, off the path).

With the rate r(τ) = 1 - s(τ/T), s(x) = 10 x³ - 15 x⁴ + 6 x⁵, the path time goes on by
T (x - S(x)), S(x) = x⁶ - 3 x⁵ + 5 x⁴ / 2 = ∫₀ˣ s, T/2 in all. A leg at speed v along the path
gets the extra acceleration r' v, at most 15/8 v/T, and jerk r'' v, at most 10/√3 v/T²;
:func:`brake_time` is the shortest T that keeps both within the stream's limits at its speed limit.
Pure Python.
"""

from __future__ import annotations

import math

from rrps_description.motion_limits import ActuatorLimits

__all__ = ['brake_time', 'braked_path_time']


def brake_time(limits: ActuatorLimits) -> float:
    """The duration T [s] of a brake from ``limits``' speed within its acceleration and jerk."""
    v, a, j = limits.speed, limits.acceleration, limits.jerk
    return max(15.0 / 8.0 * v / a, math.sqrt(10.0 / math.sqrt(3.0) * v / j))


def braked_path_time(tau: float, duration: float) -> float:
    """How far [s] the path time went on ``tau`` [s] into a brake of ``duration`` [s]: T (x - S(x))."""
    x = min(max(tau / duration, 0.0), 1.0)
    return duration * (x - x ** 6 + 3.0 * x ** 5 - 2.5 * x ** 4)
