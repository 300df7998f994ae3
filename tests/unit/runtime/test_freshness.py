"""Command freshness without synchronised clocks, and the ages of received commands
(rrps_runtime.freshness)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_runtime.freshness import CommandAges, CommandFreshness, RecentDurations, StaleCommand


def _stream(f, clock_offset, t0, t1, rate=50.0, delay=0.002):
    """Commands of a sender whose clock is ``clock_offset`` ahead, received ``delay`` after sending."""
    out = []
    for t in 1000.0 + np.arange(t0, t1, 1.0 / rate):
        try:
            out.append(f.check(t + clock_offset, t + delay))
        except StaleCommand:
            out.append(None)
    return out


def test_freshness_with_synchronised_clocks():
    f = CommandFreshness(0.1)
    with pytest.raises(StaleCommand, match='unstamped'):
        f.check(0.0, 100.0)
    assert f.check(99.95, 100.0) == pytest.approx(0.05)
    assert f.check(100.02, 100.03) == pytest.approx(0.01)
    assert f.check(100.05, 100.04) == 0.0            # a stamp a little ahead: clock skew
    with pytest.raises(StaleCommand, match='stale'):
        f.check(99.8, 100.05)                         # 0.25 s late in a live stream
    with pytest.raises(StaleCommand, match='stale'):
        f.check(math.nan, 100.06)
    with pytest.raises(StaleCommand, match='ahead'):
        f.check(102.0, 100.07)                        # far in the future: not taken on trust
    with pytest.raises(StaleCommand, match='ahead'):
        CommandFreshness(0.1).check(102.0, 100.0)     # also as the first command


@pytest.mark.parametrize('offset', [2.0, -2.0])
def test_a_sender_clock_two_seconds_off_is_learned_and_its_late_commands_refused(offset):
    f = CommandFreshness(0.1)
    ages = _stream(f, offset, 0.0, 1.0)
    accepted = [a for a in ages if a is not None]
    assert ages[0] is None and len(accepted) >= 35      # a few refused while confirming
    assert max(accepted) < 0.01                          # ages relative to the learned clock
    with pytest.raises(StaleCommand, match='stale'):
        f.check(1001.0 + offset, 1001.0 + 0.3)           # delayed 0.3 s: never acted on
    assert f.check(1001.1 + offset, 1001.1 + 0.003) < 0.01  # the stream goes on
    # after a pause the same sender is recognised at once
    assert all(a is not None for a in _stream(f, offset, 3.0, 3.5))


def test_late_commands_of_a_live_stream_are_never_acted_on():
    f = CommandFreshness(0.1)
    assert all(a is not None for a in _stream(f, 0.0, 0.0, 1.0))
    # the link queues: every command arrives 0.5 s late; while the stream is live, none passes
    late = _stream(f, 0.0, 1.0, 1.0 + f.switch_silence - 0.5, delay=0.5)  # received < 1 s later
    assert late and all(a is None for a in late)
    assert all(a is not None for a in _stream(f, 0.0, 2.5, 3.0))  # the link recovers
    # a delay that outlasts switch_silence + confirm_time is taken for a sender switch
    # (the documented limit: one-way delays cannot be told from clock offsets)
    # and its commands pass once they agree for confirm_time after switch_silence without an
    # on-time command
    later = _stream(f, 0.0, 3.0, 5.0, delay=0.5)
    refused = int(50 * (f.switch_silence - 0.5 + f.confirm_time))
    assert all(a is None for a in later[:refused]) and later[-1] is not None


def test_a_new_sender_after_silence_is_confirmed_then_accepted():
    f = CommandFreshness(0.1)
    assert all(a is not None for a in _stream(f, 0.0, 0.0, 1.0))       # teleop, same clock
    switched = _stream(f, -3.0, 2.5, 3.5)                               # 1.5 s later: another clock
    assert switched[0] is None and all(a is not None for a in switched[15:])
    assert all(a is not None for a in _stream(f, 0.0, 5.0, 5.5))       # the first sender again


@settings(max_examples=80, deadline=None)
@given(st.floats(-5.0, 5.0), st.lists(st.one_of(st.floats(0.0, 0.02), st.floats(0.15, 0.8)),
                                      min_size=30, max_size=150))
def test_a_late_command_is_never_acted_on_whatever_the_clock_offset(offset, delays):
    """One sender, its clock ``offset`` s off; its stream starts on time (2 ms), then commands
    arrive within 20 ms or late (0.15-0.8 s, beyond the 0.1 s timeout)."""
    f = CommandFreshness(0.1)
    accepted_on_time = 0
    for k, delay in enumerate([0.002] * 15 + delays):
        t = 1000.0 + 0.02 * k
        try:
            f.check(t + offset, t + delay)
        except StaleCommand:
            continue
        assert delay <= 0.02, (k, delay)
        accepted_on_time += 1
    assert accepted_on_time >= 5


def test_command_ages_summarise_the_window_and_count_stale_ones():
    ages = CommandAges(window=1.0)
    for k in range(100):
        ages.add(0.01 * k, 0.002, stale=False)
    ages.add(0.99, 0.5, stale=True)
    s = ages.summary(1.0)
    assert s['command_count'] == 101 and s['command_stale_total'] == 1
    assert s['command_age_p50_ms'] == pytest.approx(2.0)
    assert s['command_age_max_ms'] == pytest.approx(500.0)
    later = ages.summary(5.0)  # every sample left the window; the stale count stays
    assert later == {'command_count': 0, 'command_stale_total': 1}
    with pytest.raises(ValueError):
        CommandAges(window=0.0)


def test_recent_durations_give_count_p50_p99_and_max_of_the_window_in_ms():
    recent = RecentDurations(window=1.0)
    assert recent.summary(0.0) == (0, None, None, None)
    for k in range(1, 101):   # 1 .. 100 ms, one every 5 ms
        recent.add(0.005 * k, 0.001 * k)
    count, p50, p99, worst = recent.summary(0.5)
    assert count == 100 and worst == pytest.approx(100.0)
    assert p50 == pytest.approx(50.5) and p99 == pytest.approx(99.01)   # numpy's linear interpolation
    assert recent.summary(1.3025)[0] == 40   # those seen in the last second: 0.305 s on


def test_a_copy_of_recent_durations_is_summarised_apart_from_the_original():
    recent = RecentDurations(window=1.0, max_samples=3)
    for k in range(1, 4):
        recent.add(0.1 * k, 0.001 * k)
    copy = recent.copy()
    recent.add(0.4, 0.010)   # pushes the oldest out of the original only
    assert copy.summary(0.4)[::3] == (3, pytest.approx(3.0))
    assert recent.summary(0.4)[::3] == (3, pytest.approx(10.0))
    copy.add(0.5, 0.020)
    assert recent.summary(0.5)[3] == pytest.approx(10.0)
