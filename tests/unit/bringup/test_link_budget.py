"""The link budget's gates (rrps_bringup.link_budget) and the link's names (rrps_interfaces.link)."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_bringup.link_budget import ChangeGate, RateGate, StatusTable
from rrps_interfaces.link import LINK_TOPICS, normalize_namespace, robot_topic


def _admitted(gate, times, keys=None) -> list[float]:
    keys = keys if keys is not None else [None] * len(times)
    return [t for t, k in zip(times, keys) if (gate.admit(t, k) if isinstance(gate, ChangeGate) else gate.admit(t))]


def test_a_500_hz_stream_gated_at_50_hz_gives_50_of_the_newest_samples_a_second():
    times = np.arange(0.0, 10.0, 0.002) + np.random.default_rng(3).uniform(0.0, 0.0015, 5000)
    out = _admitted(RateGate(50.0), times)
    assert 495 <= len(out) <= 501
    gaps = np.diff(out)
    # on schedule: a gap differs from the period by at most one input period and its jitter
    assert 0.020 - 0.0036 <= gaps.min() and gaps.max() <= 0.020 + 0.0036


def test_after_a_gap_the_first_sample_goes_at_once_and_the_schedule_restarts():
    gate = RateGate(10.0)
    assert gate.admit(0.0) and not gate.admit(0.05) and gate.admit(0.1)
    assert gate.admit(5.0) and not gate.admit(5.09) and gate.admit(5.1)


def test_rate_zero_relays_nothing_and_a_bad_rate_is_refused():
    gate = RateGate(0.0)
    assert not gate.enabled and not gate.admit(0.0) and not gate.admit(100.0)
    for bad in (-1.0, float('nan'), float('inf')):
        with pytest.raises(ValueError):
            RateGate(bad)


def test_a_gripper_change_goes_at_once_else_the_state_at_its_rate():
    gate = ChangeGate(2.0)
    times = np.arange(0.0, 3.0, 0.05)  # the driver's 20 Hz
    keys = ['closed'] * 30 + ['open'] + ['open'] * 29
    out = _admitted(gate, times, keys)
    assert 1.5 in out  # the change, at once
    assert len(out) == 2 + 1 + 3  # 0, 0.5 | the change at 1.5 | 2.0, 2.5 (1.0 too)
    assert out == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]


def test_the_status_table_goes_out_on_a_change_at_most_every_min_interval_else_every_period():
    table = StatusTable(['driver_node', 'fk_node'], period=1.0, min_interval=0.1)
    assert not table.due(0.0)
    assert not table.offer('teleop_node', 'teleop_node: teleop', (0, 'ok'), 'x')  # not watched
    assert table.offer('driver_node', 'driver_node: driver', (0, 'ok'), 'd1')
    assert table.due(0.0) and table.take(0.0) == ['d1']
    table.offer('driver_node', 'driver_node: driver', (0, 'ok'), 'd2')  # same level and message
    assert not table.due(0.5) and table.due(1.0)
    assert table.take(1.0) == ['d2']
    table.offer('fk_node', 'fk_node: fk', (2, 'failed'), 'f1')
    assert not table.due(1.05) and table.due(1.1)
    assert table.take(1.1) == ['d2', 'f1']
    with pytest.raises(ValueError):
        StatusTable(['x'], period=0.1, min_interval=0.5)


def test_robot_topics_directly_and_over_the_link_in_any_namespace():
    assert robot_topic('pose') == 'pose'
    assert robot_topic('pose', '/robot_2') == '/robot_2/pose'
    assert robot_topic('pose', '/robot_2', 'link') == '/robot_2/link/pose'
    assert robot_topic('/diagnostics') == '/diagnostics'
    assert robot_topic('/diagnostics', '/robot_2') == '/robot_2/diagnostics'  # a fleet's: its namespace
    assert robot_topic('/diagnostics', '/robot_2', 'link') == '/robot_2/link/diagnostics'
    assert robot_topic('actuators/state', '', 'link') == 'link/actuators/state'
    assert set(LINK_TOPICS) >= {'pose', 'actuators/state', 'grippers/state', '/diagnostics'}
    with pytest.raises(ValueError, match='no link topic'):
        robot_topic('target_rings', '', 'link')
    with pytest.raises(ValueError):
        robot_topic('pose', '', 'radio')
    assert normalize_namespace('') == '' and normalize_namespace(' /robot_1 ') == '/robot_1'
    for bad in ('robot_1', '/robot_1/', '/1robot', '/a//b', '/a b'):
        with pytest.raises(ValueError):
            normalize_namespace(bad)
