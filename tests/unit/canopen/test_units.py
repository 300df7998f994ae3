"""The one conversion between metres and a drive's counts, its soft limits and its force scale,
checked against values worked out by hand."""

from __future__ import annotations

import pytest

from rrps_canopen.units import AxisScale
from rrps_description.bus import DriveConfig


def drive(**kw) -> DriveConfig:
    values = dict(actuator='leg_1', node_id=1, eds='x.eds', counts_per_metre=1e6, min_position=0.3, max_position=0.55)
    return DriveConfig(**(values | kw))


def test_counts_of_a_direct_drive():
    s = AxisScale(drive(offset=-250))
    assert s.counts(0.3) == 299_750 and s.counts(0.4250004) == 424_750
    assert s.position(424_750) == pytest.approx(0.425)
    assert s.limit_counts() == (299_750, 549_750)


def test_a_reversed_drive_counts_down_and_its_limits_swap():
    s = AxisScale(drive(direction=-1, offset=1_000_000))
    assert s.counts(0.3) == 700_000 and s.counts(0.55) == 450_000
    assert s.limit_counts() == (450_000, 700_000)
    assert s.velocity(-10_000) == pytest.approx(0.01)          # counts falling: the leg extends
    assert s.counts_per_second(0.01) == -10_000


def test_forces_are_per_mille_of_the_rated_force_signed_by_the_direction():
    assert AxisScale(drive(), rated_force=20.0).per_mille(5.0) == 250
    reversed_ = AxisScale(drive(direction=-1), rated_force=20.0)
    assert reversed_.per_mille(5.0) == -250 and reversed_.force(-250) == pytest.approx(5.0)
    assert AxisScale(drive(), rated_force=0.001).per_mille(1e6) == 32767   # INTEGER16


def test_soft_limits_and_windows():
    s = AxisScale(drive(counts_per_metre=4e6))
    assert s.within_limits(0.3) and s.within_limits(0.55) and not s.within_limits(0.5501)
    assert s.distance_counts(0.005) == 20_000 and s.distance_counts(0.0) == 1
