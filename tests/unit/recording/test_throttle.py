"""The live bridge's per-topic rate bound: at most one message per period, the newest of a burst
sent once the period has passed, unthrottled topics whole."""

from __future__ import annotations

import pytest

from rrps_recording.transport.throttle import Throttle


def test_a_500_hz_stream_goes_out_at_the_bound_and_ends_with_its_newest_message():
    throttle = Throttle(20.0, unthrottled=['/diagnostics'])
    sent = []
    for i in range(500):  # 1 s at 500 Hz
        now = i * 0.002
        if throttle.offer('/rrps/pose', i, now):
            sent.append((now, i))
        sent += [(now, m) for _, m in throttle.due(now)]
    sent += [(1.2, m) for _, m in throttle.due(1.2)]  # the burst is over
    times = [t for t, _ in sent]
    assert all(b - a >= 0.05 - 1e-9 for a, b in zip(times, times[1:]))
    assert 20 <= len(sent) <= 21 and sent[-1][1] == 499
    assert [m for _, m in sent] == sorted(m for _, m in sent)
    assert throttle.passed == len(sent) and throttle.passed + throttle.dropped == 500
    assert all(throttle.offer('/diagnostics', k, 0.0) for k in range(10))


def test_topics_are_bounded_independently_and_the_rate_must_be_positive():
    throttle = Throttle(10.0)
    assert throttle.offer('/a', 1, 0.0) and throttle.offer('/b', 1, 0.0)
    assert not throttle.offer('/a', 2, 0.05)
    assert throttle.due(0.09) == [] and throttle.due(0.1) == [('/a', 2)]
    with pytest.raises(ValueError):
        Throttle(0.0)
