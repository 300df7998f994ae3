"""The multi-host tests' settle time after a climb's stream stops at speed, against a hand
derivation of the shortest jerk-limited stop."""

from __future__ import annotations

from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_testing.multihost_stack import SETTLE, stream_stop_settle


def test_the_legs_settle_after_the_shortest_jerk_limited_stop_and_the_way_back():
    limits = ActuatorLimits(speed=0.05, acceleration=0.25, jerk=2.5)
    v, a, j = stream_limits(limits).speed, limits.acceleration, limits.jerk
    # from v at rest: the acceleration ramps to -a and back at the jerk limit (a / j each) and holds
    # -a for the rest of the speed; the distance run meanwhile is passed and must be come back
    stop = v / a + a / j
    overshoot = v * stop / 2.0
    back = 2.0 * (overshoot / a) ** 0.5       # at least: the way back at the acceleration limit
    settle = stream_stop_settle(limits)
    assert stop + back + SETTLE < settle < 2.0 * (stop + back) + SETTLE
