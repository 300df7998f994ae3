"""The robot YAML's bus section: read into typed values, every error naming its key."""

from __future__ import annotations

import copy

import pytest
import yaml

from rrps_description.bus import HOMING_ABSOLUTE, homing_end
from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot, robot_path

DATA = yaml.safe_load(robot_path('pole_climber').read_text())


def with_bus(change) -> dict:
    data = copy.deepcopy(DATA)
    change(data['bus'])
    return data


def test_the_shipped_pole_climber_has_six_drives_and_an_io_module():
    bus = load_robot('pole_climber').bus
    assert [d.actuator for d in bus.drives] == [f'leg_{i}' for i in range(1, 7)]
    assert [d.node_id for d in bus.drives] == [1, 2, 3, 4, 5, 6]
    assert bus.drives[1].direction == -1 and bus.drives[1].offset == 1_000_000
    assert all(d.homing == HOMING_ABSOLUTE and d.counts_per_metre == 1e6 for d in bus.drives)
    assert (bus.drives[0].min_position, bus.drives[0].max_position) == (0.3, 0.55)  # the stroke by default
    assert bus.grippers.io == 'cia401' and bus.grippers.node_id == 20
    assert bus.node_ids()['gripper_io'] == 20 and bus.force_output is None


def test_the_master_has_a_force_output():
    fo = load_robot('master_robot').bus.force_output
    assert (fo.limit, fo.damping) == (5.0, 2.0)


def test_a_robot_without_bus_section_has_none():
    data = copy.deepcopy(DATA)
    del data['bus']
    assert RobotGeometry.from_dict(data).bus is None


@pytest.mark.parametrize('change, message', [
    (lambda b: b['drives']['leg_3'].update(node_id=200), r'bus.drives.leg_3.node_id: must be an integer in 1..127'),
    (lambda b: b['drives']['leg_3'].update(node_id=2), r'bus: node ids must be unique'),
    (lambda b: b['grippers'].update(node_id=4), r'bus: node ids must be unique'),
    (lambda b: b['drives'].pop('leg_6'), r"bus.drives: no drive for \['leg_6'\]"),
    (lambda b: b['drives']['leg_1'].update(direction=2), r'bus.drives.leg_1.direction: must be 1 or -1'),
    (lambda b: b['drives']['leg_1'].update(max_position=0.6), r'bus.drives.leg_1: soft limits .* within the stroke'),
    (lambda b: b['drive_defaults'].update(counts_per_metre=-1), r'bus.drives.leg_1.counts_per_metre: must be > 0'),
    (lambda b: b['drive_defaults'].update(counts_per_metre=1e10), r'bus.drives.leg_1: .* 32-bit position'),
    (lambda b: b['drive_defaults'].update(homing='sometimes'),
     r"bus.drives.leg_1.homing: must be 'absolute' or a CiA 402 homing method rrps runs \(1: .*got .sometimes"),
    (lambda b: b['drive_defaults'].update(homing=19),
     r'bus.drives.leg_1.homing: .*17: the negative limit switch.*got 19'),
    (lambda b: b['drive_defaults'].update(homing=1), r'bus.drives.leg_1.home_position: missing: homing method 1 '
                                                       r'homes at an index pulse'),
    (lambda b: b['drive_defaults'].update(homing=37), r'bus.drives.leg_1.home_position: missing: homing method 37 '
                                                        r'homes at the current position'),
    (lambda b: b['drive_defaults'].update(homing=37, home_position=0.2), r'bus.drives.leg_1.home_position: 0.2 m is '
                                                                          r'outside the soft limits'),
    (lambda b: b['drive_defaults'].update(homing=17, home_position=0.3),
     r'bus.drives.leg_2.home_position: homing method 17 finds the negative limit switch, which for direction -1 is '
     r'the extended end of the stroke; 0.3 m is nearer the other end'),
    (lambda b: b.update(sdo_retries=-1), r'bus.sdo_retries: must be an integer in 0..10'),
    (lambda b: b.update(boot_timeout=0), r'bus.boot_timeout: must be > 0'),
    (lambda b: b['drive_defaults'].pop('eds'), r'bus.drives.leg_1.eds: missing'),
    (lambda b: b.update(bitrate='fast'), r'bus.bitrate: must be an integer'),
    (lambda b: b.update(heartbeat_timeout=0.01), r'bus.heartbeat_timeout: must exceed heartbeat_period'),
    (lambda b: b.update(baudrate=1), r"bus: unknown keys \['baudrate'\]"),
    (lambda b: b.pop('channel'), r'bus.channel: missing'),
    (lambda b: b['grippers'].update(io='plc'), r'bus.grippers.io: must be one of'),
    (lambda b: b['grippers']['ring_a'].pop('sensor'), r'bus.grippers.ring_a.sensor: missing'),
    (lambda b: b['grippers'].update(io='drive'), r"bus.grippers.ring_a.drive: must name a drive"),
    (lambda b: b.update(force_output={'limit': -1}), r'bus.force_output.limit: must be > 0'),
])
def test_a_malformed_bus_section_fails_naming_the_key(change, message):
    with pytest.raises(RobotDescriptionError, match=message):
        RobotGeometry.from_dict(with_bus(change), source='pole_climber.yaml')


def test_grippers_on_the_drives_name_the_drive_of_each_ring():
    def on_drives(b):
        b['grippers'] = {'io': 'drive', 'ring_a': {'drive': 'leg_1', 'output': 0, 'sensor': 16},
                         'ring_b': {'drive': 'leg_4', 'output': 0, 'sensor': 16}}
    io = RobotGeometry.from_dict(with_bus(on_drives)).bus.grippers
    assert io.io == 'drive' and io.rings['ring_b'].drive == 'leg_4' and io.rings['ring_a'].sensor == 16


def test_bring_up_timeouts_default_and_can_be_set():
    bus = load_robot('pole_climber').bus
    assert (bus.sdo_retries, bus.boot_timeout, bus.mode_timeout) == (2, 5.0, 1.0)
    changed = RobotGeometry.from_dict(with_bus(lambda b: b.update(sdo_retries=0, boot_timeout=20.0,
                                                                  mode_timeout=0.2))).bus
    assert (changed.sdo_retries, changed.boot_timeout, changed.mode_timeout) == (0, 20.0, 0.2)


@pytest.mark.parametrize('method, direction, end', [
    (17, 1, 'retracted'), (17, -1, 'extended'), (18, 1, 'extended'), (18, -1, 'retracted'),
    (1, 1, 'retracted'), (1, -1, 'extended'), (2, 1, 'extended'), (2, -1, 'retracted'),
    (35, 1, None), (37, -1, None), ('absolute', 1, None)])
def test_each_homing_method_finds_the_end_of_its_limit_switch_in_count_direction(method, direction, end):
    """CiA 402: the negative limit switch is where the count is lowest; a leg counting down as it
    extends (direction -1) has it at its extended end. Counted here from the unit conversion."""
    cpm, stroke = 1e6, (0.3, 0.55)
    counts = [direction * cpm * x for x in stroke]
    negative_end = 'retracted' if counts[0] < counts[1] else 'extended'
    other = {'retracted': 'extended', 'extended': 'retracted'}[negative_end]
    expected = {17: negative_end, 1: negative_end, 18: other, 2: other}.get(method)
    assert homing_end(method, direction) == expected == end


def test_a_limit_switch_method_homes_by_default_at_the_end_it_finds_and_says_which_keys_were_given():
    bus = RobotGeometry.from_dict(with_bus(lambda b: b['drive_defaults'].update(homing=17))).bus
    assert [d.home_position for d in bus.drives] == [0.3, 0.55, 0.3, 0.55, 0.3, 0.55]
    assert {'following_error', 'homing'} <= bus.drives[0].given and 'homing_speed' not in bus.drives[0].given
