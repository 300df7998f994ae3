"""The robot YAML's bus section: read into typed values, every error naming its key."""

from __future__ import annotations

import copy

import pytest
import yaml

from rrps_description.bus import HOMING_ABSOLUTE
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
    (lambda b: b['drive_defaults'].update(homing='sometimes'), r'bus.drives.leg_1.homing: must be an integer'),
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
