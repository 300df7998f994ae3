"""The simulated drives' homing methods against CiA 402's definitions, worked out here from the
count direction (where the count is lowest is the negative limit switch), and the statusword's
homing bits against the standard's table; the drive behaviours a test can ask for."""

from __future__ import annotations

import math

import pytest

from rrps_canopen.cia402 import HomingStatus, Statusword, homing_status
from rrps_canopen_sim.behaviour import DriveBehaviour, behaviours
from rrps_canopen_sim.homing import HomingRun, Phase
from rrps_description.bus import HOMING_METHODS, homing_end

STROKE = (0.30, 0.55)
CPM = 1e6
PITCH = 0.002


def run(method: int, direction: int, x0: float = 0.43, *, switches: bool = True, speed: float = 0.05,
        dt: float = 0.002, steps: int = 20000) -> tuple[HomingRun, float]:
    """Drive the axis as a speed-limited servo towards the run's target each step (stroke-clipped)
    until the run is done or failed; (the run, where the axis ended)."""
    h = HomingRun(method, x0, direction * CPM, STROKE, switches=switches, index_pitch=PITCH)
    x = x0
    for _ in range(steps):
        if h.phase in (Phase.DONE, Phase.FAILED):
            break
        target = min(max(h.target, STROKE[0]), STROKE[1])
        x_new = x + max(-speed * dt, min(speed * dt, target - x))
        h.advance(x, x_new)
        x = x_new
    return h, x


def end_of_lowest_count(direction: int) -> float:
    """The stroke end where the count (direction * CPM * length) is lowest."""
    return min(STROKE, key=lambda x: direction * CPM * x)


@pytest.mark.parametrize('direction', [1, -1])
@pytest.mark.parametrize('method', [17, 18])
def test_limit_switch_methods_home_at_the_switch_in_count_direction(method, direction):
    negative = end_of_lowest_count(direction)
    positive = STROKE[1] if negative == STROKE[0] else STROKE[0]
    expected = negative if method == 17 else positive
    h, x = run(method, direction)
    assert h.phase is Phase.DONE and h.home == expected and x == pytest.approx(expected, abs=1e-9)
    assert homing_end(method, direction) == ('retracted' if expected == STROKE[0] else 'extended')


@pytest.mark.parametrize('direction', [1, -1])
@pytest.mark.parametrize('method', [1, 2])
def test_index_methods_home_on_the_first_pulse_back_inside_from_the_switch(method, direction):
    switch = end_of_lowest_count(direction) if method == 1 else (
        STROKE[1] if end_of_lowest_count(direction) == STROKE[0] else STROKE[0])
    pulses = [STROKE[0] + (k + 0.5) * PITCH for k in range(round((STROKE[1] - STROKE[0]) / PITCH))]
    expected = min(pulses, key=lambda p: abs(p - switch))  # the pulse nearest the switch, inside the stroke
    h, x = run(method, direction)
    assert h.phase is Phase.DONE and h.home == pytest.approx(expected, abs=1e-12)
    assert abs(x - expected) < 0.05 * 0.002 + 1e-12  # stops within a step of the pulse


@pytest.mark.parametrize('method', [35, 37])
def test_current_position_methods_home_where_the_axis_stands(method):
    h, x = run(method, -1, x0=0.4321)
    assert h.phase is Phase.DONE and h.home == 0.4321 and x == 0.4321


@pytest.mark.parametrize('method', [1, 17, 18])
def test_without_limit_switches_a_switch_method_fails_at_the_hard_stop(method):
    h, x = run(method, 1, switches=False)
    assert h.phase is Phase.FAILED and h.home is None and min(abs(x - e) for e in STROKE) < 1e-9


def test_every_method_rrps_offers_is_simulated():
    for method in HOMING_METHODS:
        assert HomingRun(method, 0.4, CPM, STROKE, switches=True, index_pitch=PITCH).phase is not Phase.FAILED


@pytest.mark.parametrize('bits, status', [
    (0b000, HomingStatus.IN_PROGRESS), (0b001, HomingStatus.NOT_STARTED), (0b010, HomingStatus.ATTAINED),
    (0b011, HomingStatus.COMPLETED), (0b100, HomingStatus.ERROR), (0b101, HomingStatus.ERROR)])
def test_homing_status_is_the_table_of_bits_13_12_10(bits, status):
    """CiA 402, homing mode: bit 13 homing error, bit 12 homing attained, bit 10 target reached."""
    word = 0x0237 | (bits >> 2 & 1) << 13 | (bits >> 1 & 1) << 12 | (bits & 1) << 10
    assert homing_status(word) is status
    assert bool(word & Statusword.MODE_SPECIFIC_12) == bool(bits & 0b010)


def test_behaviours_apply_to_every_drive_or_the_named_one_and_unknown_options_are_refused():
    kinds = behaviours({'mode_delay': 0.05, 'leg_2': {'homing_methods': [35], 'refuse': ['0x605A']}},
                       ['leg_1', 'leg_2'])
    assert kinds['leg_1'] == DriveBehaviour(mode_delay=0.05)
    assert kinds['leg_2'].homing_methods == (35,) and kinds['leg_2'].refuse == (0x605A,)
    assert kinds['leg_2'].mode_delay == 0.05
    with pytest.raises(ValueError, match=r"unknown drive behaviour \['mode_dalay'\]"):
        behaviours({'mode_dalay': 1}, ['leg_1'])
    with pytest.raises(ValueError, match='pdo_layout must be one of'):
        behaviours({'pdo_layout': 'odd'}, ['leg_1'])


def test_supported_modes_are_bit_m_minus_1():
    """CiA 402 0x6502: bit 5 homing (6), bit 7 CSP (8), bit 9 CST (10)."""
    assert DriveBehaviour().supported_modes() == 0x2A0
    assert DriveBehaviour(modes=(8,)).supported_modes() == int(math.pow(2, 7))
