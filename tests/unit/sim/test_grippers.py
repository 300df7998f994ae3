"""The gripper interlock: the robot never lets go of the structure with both rings."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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
