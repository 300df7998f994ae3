"""Where homing may leave the legs before the robot is activated: each homed leg at its home
position, every leg within its stroke, the six lengths a pose of the robot (forward kinematics
converges, within the limits after homing). Lengths made by the inverse kinematics (eq. 1) of
known poses. And when a CANopen robot counts as at rest: its velocity resolution."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import yaml

from rrps_canopen.homing import check_positions
from rrps_canopen.units import AxisScale
from rrps_description.geometry import RobotGeometry, load_robot, robot_path
from rrps_hardware.interface import ActuatorStatus, SystemState
from rrps_kinematics.inverse import inverse_kinematics

POLE = load_robot('pole_climber')


def homing_bus(**defaults):
    data = copy.deepcopy(yaml.safe_load(robot_path('pole_climber').read_text()))
    data['bus']['drive_defaults'].update(defaults)
    return RobotGeometry.from_dict(data).bus.drives


def test_the_home_pose_after_homing_is_plausible():
    lengths = inverse_kinematics(POLE, POLE.home_position, POLE.home_quaternion_xyzw).lengths
    drives = tuple(dataclasses.replace(d, homing=37, home_position=float(x)) for d, x in zip(homing_bus(), lengths))
    assert check_positions(POLE, drives, lengths, {d.actuator for d in drives}) == {}


def test_a_leg_that_homed_away_from_its_home_position_is_named():
    drives = homing_bus(homing=17)  # home at the retracted end of direction-1 legs, the extended end of the others
    lengths = np.array([0.3, 0.55, 0.3, 0.55, 0.3, 0.55])
    lengths[0] = 0.0  # the drive never homed: its incremental count still reads 0
    problems = check_positions(POLE, drives, lengths, {'leg_1'})
    assert list(problems) == ['leg_1'] and 'homed at 0.0000 m, not at its home position 0.3000 m' in problems['leg_1']


def test_a_leg_outside_its_stroke_is_named_and_the_tolerance_is_the_following_error_window():
    drives = homing_bus()
    lengths = np.array(inverse_kinematics(POLE, POLE.home_position, POLE.home_quaternion_xyzw).lengths)
    lengths[3] = 1.0
    problems = check_positions(POLE, drives, lengths, set())
    assert list(problems) == ['leg_4'] and 'reads 1.0000 m, outside the stroke [0.3, 0.55] m' in problems['leg_4']
    lengths[3] = POLE.max_length + 0.9 * drives[3].following_error  # within the drive's own window: a pose?
    assert 'outside the stroke' not in ' '.join(check_positions(POLE, drives, lengths, set()).values())


def test_lengths_that_assemble_no_pose_are_refused_for_every_leg():
    """Three legs at the retracted end, three at the extended end: no pose of the pole climber has
    them (the forward kinematics from the home pose does not converge)."""
    drives = homing_bus(homing=17)
    lengths = np.array([0.3, 0.55, 0.3, 0.55, 0.3, 0.55])
    problems = check_positions(POLE, drives, lengths, {d.actuator for d in drives})
    assert set(problems) == {f'leg_{i}' for i in range(1, 7)}
    assert all('assemble no pose of the robot' in p for p in problems.values())


def test_all_legs_at_an_end_is_a_pose_within_the_limits():
    for end in (0.3, 0.55):
        drives = tuple(dataclasses.replace(d, homing=37, home_position=end) for d in homing_bus())
        assert check_positions(POLE, drives, np.full(6, end), {d.actuator for d in drives}) == {}


def test_a_still_canopen_axis_is_at_rest_although_its_velocity_reads_a_count_or_two():
    """A drive differentiates its encoder count: at rest it reads +-1 count per sample."""
    drive = POLE.bus.drives[0]
    period = POLE.bus.sync_period
    rest = AxisScale(drive).rest_speed(period)
    assert rest == 2 / (drive.counts_per_metre * period)  # 2 counts per SYNC period: 1 mm/s at 1 um, 2 ms
    dither = np.array([1, -1, 0, 1, -2, 0]) / (drive.counts_per_metre * period)
    statuses = tuple(ActuatorStatus(f'leg_{i}', True, True, True) for i in range(1, 7))

    def state(velocities):
        return SystemState(np.full(6, 0.4), velocities, np.zeros(6), np.full(6, 0.4), {}, statuses, rest_speed=rest)
    assert state(dither).at_rest()
    assert not state(dither * 5).at_rest()
    assert not SystemState(np.full(6, 0.4), dither, np.zeros(6), np.full(6, 0.4), {}, statuses).at_rest()
