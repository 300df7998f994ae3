"""The CiA 402 power state machine, checked against the profile's tables (IEC 61800-7-201
tables 28 and 30), on both sides: the statusword a device reports and the controlword the
backend picks."""

from __future__ import annotations

import pytest

from rrps_canopen.cia402 import ENABLE_PATH, Controlword, DeviceStateMachine, State, controlword_toward, state_of


@pytest.mark.parametrize('word, state', [
    (0x0000, State.NOT_READY_TO_SWITCH_ON), (0x0040, State.SWITCH_ON_DISABLED), (0x0250, State.SWITCH_ON_DISABLED),
    (0x0021, State.READY_TO_SWITCH_ON), (0x0231, State.READY_TO_SWITCH_ON), (0x0023, State.SWITCHED_ON),
    (0x0027, State.OPERATION_ENABLED), (0x1637, State.OPERATION_ENABLED), (0x0007, State.QUICK_STOP_ACTIVE),
    (0x000F, State.FAULT_REACTION_ACTIVE), (0x0008, State.FAULT), (0x2218, State.FAULT),
])
def test_the_statusword_tells_the_state(word, state):
    assert state_of(word) is state


def test_a_device_reports_what_it_is_and_the_backend_reads_it_back():
    device = DeviceStateMachine()
    seen = []
    while device.state is not State.OPERATION_ENABLED:
        seen.append(device.state)
        device.on_controlword(controlword_toward(state_of(device.statusword()), State.OPERATION_ENABLED))
        assert state_of(device.statusword()) is device.state
    assert tuple(seen) + (device.state,) == ENABLE_PATH


def test_enable_path_controlwords_are_the_profiles():
    assert controlword_toward(State.SWITCH_ON_DISABLED, State.OPERATION_ENABLED) == 0x06
    assert controlword_toward(State.READY_TO_SWITCH_ON, State.OPERATION_ENABLED) == 0x07
    assert controlword_toward(State.SWITCHED_ON, State.OPERATION_ENABLED) == 0x0F
    assert controlword_toward(State.OPERATION_ENABLED, State.OPERATION_ENABLED) is None
    assert controlword_toward(State.OPERATION_ENABLED, State.SWITCH_ON_DISABLED) == 0x00
    assert controlword_toward(State.QUICK_STOP_ACTIVE, State.OPERATION_ENABLED) == 0x00


def test_the_backend_never_resets_a_fault_on_its_way():
    assert controlword_toward(State.FAULT, State.OPERATION_ENABLED) is None
    assert controlword_toward(State.FAULT_REACTION_ACTIVE, State.SWITCH_ON_DISABLED) is None


def test_quick_stop_stops_an_enabled_drive_and_holds_it():
    device = DeviceStateMachine()
    for word in (0x06, 0x07, 0x0F):
        device.on_controlword(word)
    assert device.on_controlword(Controlword.QUICK_STOP) is State.QUICK_STOP_ACTIVE
    assert device.on_controlword(Controlword.QUICK_STOP) is State.QUICK_STOP_ACTIVE
    assert device.on_controlword(Controlword.DISABLE_VOLTAGE) is State.SWITCH_ON_DISABLED


def test_a_fault_is_left_only_on_a_rising_edge_of_the_reset_bit():
    device = DeviceStateMachine()
    for word in (0x06, 0x07, 0x0F):
        device.on_controlword(word)
    device.fault()
    assert state_of(device.statusword()) is State.FAULT
    assert device.on_controlword(0x0F) is State.FAULT           # enabling does nothing
    device._reset_bit = True                                     # the bit already high: no edge
    assert device.on_controlword(0x80) is State.FAULT
    assert device.on_controlword(0x00) is State.FAULT
    assert device.on_controlword(0x80) is State.SWITCH_ON_DISABLED
