"""The gripper interlock: the robot never lets go of the structure with both rings."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.motion_limits import GripperTime
from rrps_sim.grippers import RINGS, Grippers

CLAMPS = {'ring_a': 'clamp', 'ring_b': 'clamp'}


def test_opening_one_ring_while_the_other_is_open_is_refused():
    g = Grippers(CLAMPS)
    assert g.positions() == [1.0, 1.0]
    assert g.set('ring_b', close=False) == (True, 'ring_b open')
    ok, message = g.set('ring_a', close=False)
    assert not ok and 'ring_b is open' in message
    assert g.positions() == [1.0, 0.0]
    assert g.set('ring_b', close=True)[0]
    assert g.set('ring_a', close=False)[0]
    assert g.positions() == [0.0, 1.0]
    assert g.set('ring_a', close=False) == (True, 'ring_a already open')


def test_unknown_ring_and_missing_gripper_are_refused():
    g = Grippers({'ring_a': 'none', 'ring_b': 'suction'})
    assert g.set('ring_c', close=True)[0] is False
    ok, message = g.set('ring_a', close=False)
    assert not ok and 'no gripper' in message
    assert g.set('ring_b', close=False)[0]  # ring_a (no gripper) is fixed: counts as closed
    assert g.positions() == [1.0, 0.0]


def test_invalid_construction():
    with pytest.raises(ValueError, match='at least one'):
        Grippers(CLAMPS, closed={'ring_a': False, 'ring_b': False})
    with pytest.raises(ValueError, match='missing'):
        Grippers({'ring_a': 'clamp'})


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(RINGS), st.booleans()), max_size=30))
def test_never_both_open(commands):
    g = Grippers(CLAMPS)
    for ring, close in commands:
        before = g.positions()
        ok, _ = g.set(ring, close)
        assert max(g.positions()) == 1.0
        if not ok:
            assert g.positions() == before


TIMES = {'ring_a': GripperTime(open=0.5, close=0.8), 'ring_b': GripperTime(open=0.4, close=1.5)}


def test_a_timed_gripper_switches_once_its_time_has_passed():
    """The sensor (closed) shows the end last reached: ring_b open 0.4 s after the command, closed
    again 1.5 s after that one; every 10 ms stepped."""
    g = Grippers(CLAMPS, times=TIMES)
    g.update(0.0)
    assert g.set('ring_b', close=False) == (True, 'ring_b opening (0.4 s)')
    switched = next(k for k in range(1, 200) if g.update(k * 0.01))
    assert switched * 0.01 == pytest.approx(0.4) and g.closed == {'ring_a': True, 'ring_b': False}
    t0 = switched * 0.01
    assert g.set('ring_b', close=True)[1] == 'ring_b closing (1.5 s)'
    switched = next(k for k in range(1, 400) if g.update(t0 + k * 0.01))
    assert switched * 0.01 == pytest.approx(1.5) and g.positions() == [1.0, 1.0]


def test_a_ring_still_opening_or_closing_does_not_count_for_the_interlock():
    g = Grippers(CLAMPS, times=TIMES)
    g.update(0.0)
    assert g.set('ring_b', close=False)[0]
    ok, message = g.set('ring_a', close=False)   # ring_b's sensor still reads closed: it is opening
    assert not ok and 'ring_b is opening' in message
    g.update(0.5)
    assert g.set('ring_b', close=True)[0]
    ok, message = g.set('ring_a', close=False)   # ring_b closing, its sensor reads open
    assert not ok and 'ring_b is closing' in message
    g.update(0.5 + 1.5)
    assert g.set('ring_a', close=False)[0]


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(RINGS), st.booleans(), st.floats(0.0, 2.0)), max_size=30))
def test_timed_grippers_never_let_go(commands):
    """Whatever the commands and whenever they come, at every time one ring is fully closed."""
    g = Grippers(CLAMPS, times=TIMES)
    t = 0.0
    g.update(t)
    for ring, close, wait in commands:
        g.set(ring, close)
        for _ in range(4):
            t += wait / 4
            g.update(t)
            assert any(g.travel[r] == 1.0 and g.closed[r] for r in RINGS), (g.travel, g.closed)
