"""Homing CiA 402 drives that behave differently but within the standard: a drive that shows a new
mode in 0x6061 50 or 20 ms after the request, homing methods 17 and 18 on legs of either count
direction, method 37 on drives that enforce their software limits from power-on, the index
methods, and a drive without limit switches. The simulated drives (rrps-drive-sim, a process of
their own, real CANopen traffic on a loopback bus) are configured to behave so; the CANopen
hardware of the driver runs in this process. Each test ends with the legs where the driver
believes they are (within one encoder count) or with a clear refusal and every drive disabled.

Every wait is a generous deadline that returns as soon as the thing happened (a loaded 2-core
machine)."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_hardware.interface import FaultKind, HardwareConfig
from rrps_testing.canopen_rig import UNHURRIED_BUS, DriveSim, canopen_hardware, cycle_to, robot_yaml
from rrps_testing.ros_harness import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.exclusive]  # the drive simulator and driver at SCHED_RR
POLE = load_robot('pole_climber')
#: [m] one encoder count of the shipped pole climber's drives.
COUNT = 1.0 / POLE.bus.drives[0].counts_per_metre
#: Incremental encoders homed at the retracted end: the negative limit switch (17) of the legs
#: that count up as they extend, the positive one (18) of those that count down (direction -1).
RETRACTED = {'homing': 17, 'homing_speed': 0.05}
DIRECTION_MINUS = {'leg_2': {'homing': 18}, 'leg_4': {'homing': 18}, 'leg_6': {'homing': 18}}


def start(sim: DriveSim, hardware, path: str):
    outcome = hardware.on_configure(HardwareConfig(load_robot(path), {}))
    assert outcome.ok, outcome.reason
    drives = sim.status()['drives']
    assert {d['state'] for d in drives.values()} == {'switch_on_disabled'}, drives
    return outcome


def where_believed(sim: DriveSim, hardware) -> bool:
    """The lengths the driver reads agree with the simulated axes' within one count."""
    return bool(np.all(np.abs(hardware.read(0.0, 0.0).positions - sim.positions()) <= COUNT))


def assert_disabled_and_still(sim: DriveSim, lengths) -> None:
    drives = sim.status()['drives']
    assert {d['state'] for d in drives.values()} == {'switch_on_disabled'}, drives
    np.testing.assert_allclose(sim.positions(), lengths, atol=1e-12)


def moves_on_command(hardware, sim: DriveSim) -> None:
    """An accepted command (a step within the following-error window) moves every leg there, and
    the driver reads it there."""
    goal = hardware.read(0.0, 0.0).positions + 0.002
    assert cycle_to(hardware, goal, arrived=lambda: np.allclose(sim.positions(), goal, atol=2 * COUNT)), \
        sim.positions()
    assert wait_for(lambda: where_believed(sim, hardware), timeout=10.0)


@pytest.mark.parametrize('mode_delay', [0.05, 0.02])
def test_a_drive_that_changes_mode_late_is_homed_and_then_follows(tmp_path, mode_delay):
    """0x6061 shows a new mode ``mode_delay`` after 0x6060 is written: the backend waits for it
    before it enables the drive, starts homing and reads the homing bits."""
    path = robot_yaml(tmp_path / 'late.yaml', bus=UNHURRIED_BUS, drive_defaults=RETRACTED,
                      drives=DIRECTION_MINUS)
    with DriveSim(path, behaviour={'mode_delay': mode_delay}) as sim, canopen_hardware(sim) as hardware:
        start(sim, hardware, path)
        outcome = hardware.on_activate()
        assert outcome.ok, outcome.reason
        drives = sim.status()['drives']
        assert all(d['homed'] and d['mode'] == 8 and d['state'] == 'operation_enabled' for d in drives.values())
        np.testing.assert_allclose(sim.positions(), POLE.min_length, atol=1e-9)  # the retracted end
        assert wait_for(lambda: where_believed(sim, hardware), timeout=10.0)
        assert all(a.homed for a in hardware.read(0.0, 0.0).actuators)
        moves_on_command(hardware, sim)


def test_method_17_finds_the_extended_end_of_a_leg_counting_down_and_says_the_legs_cannot_be_there(tmp_path):
    """CiA 402's method 17 is the negative limit switch in count direction: for ``direction: -1``
    the extended end. By default home_position is that end, so the driver believes the legs
    where they are; three legs retracted and three extended are no pose of the robot: activation
    refused, every drive disabled, a homing fault on each leg."""
    path = robot_yaml(tmp_path / 'seventeen.yaml', bus=UNHURRIED_BUS, drive_defaults=RETRACTED)
    with DriveSim(path) as sim, canopen_hardware(sim) as hardware:
        start(sim, hardware, path)
        outcome = hardware.on_activate()
        assert not outcome.ok and 'assemble no pose of the robot' in outcome.reason, outcome.reason
        np.testing.assert_allclose(sim.positions(), [0.3, 0.55] * 3, atol=1e-9)
        assert wait_for(lambda: where_believed(sim, hardware), timeout=10.0)
        drives = sim.status()['drives']
        assert {d['state'] for d in drives.values()} == {'switch_on_disabled'}, drives
        faults = hardware.read(0.0, 0.0).faults
        assert {f.actuator for f in faults} == {f'leg_{i}' for i in range(1, 7)}
        assert {f.kind for f in faults} == {FaultKind.HOMING}
        assert not hardware.on_activate().ok  # a fault never re-enables by itself


def test_method_37_with_limits_enforced_from_power_on_moves_nothing_before_homing(tmp_path):
    """Incremental encoders read 0 at power-on, outside the software limits the drives enforce
    from power-on: the drives are enabled in homing mode, where they follow no target, and homed
    where they stand (home_position: the robot on its stand)."""
    lengths = physical_start = POLE.home_lengths
    path = robot_yaml(tmp_path / 'here.yaml', bus=UNHURRIED_BUS, drive_defaults={'homing': 37},
                      drives={f'leg_{i}': {'home_position': float(x)} for i, x in enumerate(lengths, 1)})
    with DriveSim(path, behaviour={'limits_before_homing': True}) as sim, canopen_hardware(sim) as hardware:
        start(sim, hardware, path)
        sim.ask(cmd='trace', on=True)
        outcome = hardware.on_activate()
        activated = time.monotonic()
        assert outcome.ok, outcome.reason
        assert wait_for(lambda: where_believed(sim, hardware), timeout=10.0)
        # traced: every SYNC from before the activation to one after it (one machine's monotonic clock)
        assert wait_for(lambda: max(sim.ask(cmd='syncs')['syncs'], default=0.0) > activated, timeout=10.0)
        trace = sim.ask(cmd='trace', on=False)['trace']
        assert trace[-1][0] > activated
        moved = np.max(np.abs(np.array([row[2] for row in trace]) - physical_start))
        assert moved <= 1e-9, moved
        moves_on_command(hardware, sim)


def test_enabled_in_position_mode_before_homing_such_a_drive_moves(tmp_path):
    """The simulated drives of the test above do what the issue saw: enabled in cyclic
    synchronous position mode before homing, their limits pull the legs off where they stand."""
    from rrps_canopen.cia402 import Mode
    from rrps_canopen.drive_set import DriveSet
    from rrps_canopen.homing import set_mode
    path = robot_yaml(tmp_path / 'early.yaml', bus=UNHURRIED_BUS,
                      drive_defaults={'homing': 37, 'home_position': 0.425})
    with DriveSim(path, behaviour={'limits_before_homing': True}) as sim, canopen_hardware(sim):
        drives = DriveSet(load_robot(path).bus, Mode.CYCLIC_SYNCHRONOUS_POSITION)
        try:
            drives.configure()
            assert set_mode(drives, drives.drives, Mode.CYCLIC_SYNCHRONOUS_POSITION) == ''
            drives.enable()
            assert wait_for(lambda: np.max(np.abs(sim.positions() - POLE.home_lengths)) > 1e-3, timeout=10.0)
        finally:
            drives.disable()
            drives.close(stop_drives=True)


def test_the_index_methods_home_on_the_pulse_next_to_the_switch(tmp_path):
    """Method 1 (negative switch, then the index) on the legs that count up, 2 (positive switch)
    on those that count down: both at the pulse half a pitch inside the retracted end."""
    pitch = 0.002
    home = POLE.min_length + pitch / 2
    path = robot_yaml(tmp_path / 'index.yaml', bus=UNHURRIED_BUS,
                      drive_defaults={'homing': 1, 'home_position': home, 'homing_speed': 0.05},
                      drives={leg: {'homing': 2} for leg in DIRECTION_MINUS})
    with DriveSim(path, behaviour={'index_pitch': pitch}) as sim, canopen_hardware(sim) as hardware:
        start(sim, hardware, path)
        outcome = hardware.on_activate()
        assert outcome.ok, outcome.reason
        np.testing.assert_allclose(sim.positions(), home, atol=0.2 * pitch)
        assert wait_for(lambda: where_believed(sim, hardware), timeout=10.0)


def test_a_drive_without_limit_switches_fails_homing_and_nothing_is_enabled(tmp_path):
    path = robot_yaml(tmp_path / 'noswitch.yaml', bus=UNHURRIED_BUS, drive_defaults=RETRACTED,
                      drives=DIRECTION_MINUS)
    behaviour = {'leg_3': {'limit_switches': False}}
    with DriveSim(path, behaviour=behaviour) as sim, canopen_hardware(sim) as hardware:
        start(sim, hardware, path)
        t0 = time.monotonic()
        outcome = hardware.on_activate()
        assert not outcome.ok and 'homing error (statusword bit 13) on leg_3 (node 3)' in outcome.reason, \
            outcome.reason
        assert time.monotonic() - t0 < 60.0
        drives = sim.status()['drives']
        assert {d['state'] for d in drives.values()} == {'switch_on_disabled'}, drives
        faults = hardware.read(0.0, 0.0).faults
        assert [(f.actuator, f.kind) for f in faults] == [('leg_3', FaultKind.HOMING)], faults


def test_a_drive_slower_to_change_mode_than_mode_timeout_is_named_and_nothing_moves(tmp_path):
    path = robot_yaml(tmp_path / 'slow.yaml', bus={**UNHURRIED_BUS, 'mode_timeout': 0.2}, drive_defaults=RETRACTED,
                      drives=DIRECTION_MINUS)
    with DriveSim(path, behaviour={'leg_5': {'mode_delay': 1.0}}) as sim, canopen_hardware(sim) as hardware:
        start(sim, hardware, path)
        outcome = hardware.on_activate()
        assert not outcome.ok
        assert re.fullmatch(r'activation failed: leg_5 \(node 5\) still shows (no mode|cyclic synchronous position '
                            r'mode) in 0x6061 modes of operation display 0.2 s after homing mode was written '
                            r'\(bus.mode_timeout\): drives disabled', outcome.reason), outcome.reason
        assert_disabled_and_still(sim, POLE.home_lengths)
        assert not hardware.read(0.0, 0.0).faults  # not a fault: activating again may do
