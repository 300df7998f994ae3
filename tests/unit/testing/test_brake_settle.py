"""The multi-host tests' settle time after a paused climb's last target, against the brake it
follows: the legs reach that target within one more brake's time."""

from __future__ import annotations

from rrps_climbing.path_brake import brake_time
from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_testing.multihost_stack import SETTLE, brake_settle


def test_the_legs_settle_within_a_brake_time_after_the_braked_streams_last_target():
    limits = ActuatorLimits(speed=0.05, acceleration=0.25, jerk=2.5)
    assert SETTLE < brake_settle(limits) < SETTLE + brake_time(stream_limits(limits))
