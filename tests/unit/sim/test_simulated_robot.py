"""The simulated robot through the hardware interface alone (rrps_hardware.registry): lifecycle order,
write/read tracking, the gripper interlock, per-actuator faults and their reset, persisted state."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.names import LEG_NAMES
from rrps_hardware.commands import checked_command
from rrps_hardware.interface import (
    ActuatorFault,
    BusState,
    CallbackReturn,
    Command,
    FaultKind,
    HardwareConfig,
    ReturnType,
    SystemInterface,
)
from rrps_hardware.registry import hardware_class
from rrps_kinematics import inverse_kinematics
from rrps_runtime.freshness import RejectedCommand
from rrps_sim.hardware_state import load_state
from rrps_sim.simulated_robot import SimulatedRobot

POLE = load_robot('pole_climber')
FRAME = load_robot('frame_climber')
DT = 0.01
#: an ideal kinematic robot: no lag, so each leg moves at max_speed until it is there
IDEAL = {'time_constant': 0.0}
GOAL = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.01], [0, 0, 0, 1]).lengths


def configured(geometry=POLE, **parameters) -> SimulatedRobot:
    robot = SimulatedRobot()
    outcome = robot.on_configure(HardwareConfig(geometry, {**IDEAL, **parameters}))
    assert outcome.ok, outcome.reason
    return robot


def active(geometry=POLE, **parameters) -> SimulatedRobot:
    robot = configured(geometry, **parameters)
    assert robot.on_activate().ok
    return robot


def cycle(robot, command=None, n=1, t0=0.0):
    """n cycles of write then read; the last result and state."""
    for k in range(n):
        result = robot.write(t0 + k * DT, DT, command)
        state = robot.read(t0 + k * DT, DT)
    return result, state


def test_the_simulated_robot_is_registered_by_name():
    assert hardware_class('simulated') is SimulatedRobot
    assert issubclass(SimulatedRobot, SystemInterface)
    with pytest.raises(ValueError, match=r"unknown hardware 'cia402'; known: .*simulated"):
        hardware_class('cia402')


def test_nothing_moves_before_activate():
    robot = SimulatedRobot()
    assert robot.write(0.0, DT, Command(GOAL)).code is ReturnType.ERROR
    nothing = robot.read(0.0, DT)
    assert nothing.lost and nothing.actuators == ()
    assert robot.on_activate().code is CallbackReturn.FAILURE  # not configured
    robot = configured()
    result, state = cycle(robot, Command(GOAL), n=50)
    assert result.code is ReturnType.ERROR and 'inactive' in result.message
    np.testing.assert_array_equal(state.positions, POLE.home_lengths)
    assert not any(a.enabled for a in state.actuators)
    assert robot.set_gripper('ring_b', close=False).code is ReturnType.ERROR
    assert state.grippers == {'ring_a': True, 'ring_b': True}
    assert robot.on_activate().ok
    _, state = cycle(robot, Command(GOAL), n=50)
    assert all(a.enabled and a.homed for a in state.actuators)
    assert not np.array_equal(state.positions, POLE.home_lengths)


def _limits_by_differences(x, dt):
    """The largest |speed|, |acceleration| and |jerk| of samples x (k, 6) every dt: finite differences."""
    v = np.diff(x, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    return np.abs(v).max(), np.abs(a).max(), np.abs(np.diff(a, axis=0) / dt).max()


def test_write_then_read_moves_to_a_step_command_within_the_speed_acceleration_and_jerk_limits():
    robot = active()
    start, limits = POLE.home_lengths, POLE.motion_limits.legs
    positions = [start]
    for n in range(1, 1000):
        result, state = cycle(robot, Command(GOAL), t0=n * DT)
        assert result.ok
        positions.append(state.positions)
        if np.array_equal(state.positions, GOAL):
            break
    x = np.array(positions)
    speed, acceleration, jerk = _limits_by_differences(x, DT)
    assert speed <= limits.speed * (1 + 1e-9) and acceleration <= limits.acceleration * (1 + 1e-9)
    assert jerk <= limits.jerk * (1 + 1e-6)
    # each leg moves toward its goal, never past it, and not much slower than a rest-to-rest
    # motion at the jerk limit alone would allow: t >= (32 d / j)^(1/3) for a distance d
    assert np.all((x - start) * np.sign(GOAL - start) >= -1e-12)
    assert np.all((GOAL - x) * np.sign(GOAL - start) >= -1e-12)
    fastest = (32.0 * np.abs(GOAL - start).max() / limits.jerk) ** (1.0 / 3.0)
    assert fastest <= len(x) * DT <= 3.0 * fastest + 1.0
    assert all(a.target_reached for a in state.actuators) and [a.name for a in state.actuators] == list(LEG_NAMES)
    np.testing.assert_array_equal(state.targets, GOAL)
    assert state.bus is BusState.OPERATIONAL and state.faults == ()
    _, state = cycle(robot)  # no command: the actuators keep their target
    np.testing.assert_array_equal(state.positions, GOAL)
    np.testing.assert_array_equal(state.velocities, np.zeros(6))


def test_a_command_stream_is_followed_one_period_behind_within_the_limits():
    """A stream at 50 Hz along a smooth ramp (a leg's planned motion), each command stamped with its
    sample's time: the legs follow it one command period behind, within 3 mm while it accelerates
    and 0.5 mm once it cruises, every sample within the limits."""
    robot = active()
    start, limits = POLE.home_lengths, POLE.motion_limits.legs
    ramp = 0.9 * limits.speed
    t_ramp = 2.0 * ramp / (0.9 * limits.acceleration)

    def planned(t):   # accelerate smoothly (a 1 - cos acceleration) to 90 % of the speed, then cruise
        t = np.clip(np.atleast_1d(t), 0.0, None)
        w = 2.0 * np.pi / t_ramp
        s = np.where(t < t_ramp, ramp * (t ** 2 / (2.0 * t_ramp) + (np.cos(w * t) - 1.0) / (w ** 2 * t_ramp)),
                     ramp * (t - t_ramp / 2.0))
        return start + s[:, None] if s.size > 1 else start + s[0]

    x = []
    for n in range(200):   # 2 s (0.09 m, within the stroke), a command every other cycle
        t = n * DT
        sample = t - t % 0.02   # the stream's sample time, its stamp (driver_node stamps commands so)
        command = Command(planned(sample), stamp=sample)
        if n % 2 == 0:
            stream = command
        robot.write(t, DT, stream)
        x.append(robot.read(t, DT).positions)
    x = np.array(x)
    speed, acceleration, jerk = _limits_by_differences(x, DT)
    assert speed <= limits.speed * (1 + 1e-9) and acceleration <= limits.acceleration * (1 + 1e-9)
    assert jerk <= limits.jerk * (1 + 1e-6)
    behind = planned(np.arange(200) * DT - 0.02)
    error = np.abs(x - behind).max(axis=1)
    assert error.max() < 3e-3 and error[100:].max() < 5e-4   # caught up once the stream cruises


def test_ring_rotations_are_commanded_with_the_legs():
    robot = active(FRAME)
    names = [a.name for a in robot.read(0.0, DT).actuators]
    assert names == list(LEG_NAMES) + ['ring_a_rotation', 'ring_b_rotation']
    result, state = cycle(robot, Command(FRAME.home_lengths, np.array([0.0, 0.1])), n=100)
    assert result.ok
    np.testing.assert_allclose(state.ring_positions, [0.0, 0.1], atol=1e-12)
    assert robot.write(0.0, DT, Command(FRAME.home_lengths, np.array([0.1]))).code is ReturnType.ERROR


def test_a_refused_gripper_release_is_a_return_value_with_the_reason():
    robot = active()
    cycle(robot)
    assert robot.set_gripper('ring_b', close=False).ok
    refused = robot.set_gripper('ring_a', close=False)   # ring_b is still opening
    assert refused.code is ReturnType.ERROR and 'ring_b is opening' in refused.message
    _, state = cycle(robot, n=60)                        # ring_b's open time (0.5 s, the YAML's) has passed
    assert state.grippers == {'ring_a': True, 'ring_b': False}
    refused = robot.set_gripper('ring_a', close=False)
    assert refused.code is ReturnType.ERROR and 'ring_b is open ' in refused.message
    assert robot.set_gripper('ring_c', close=True).code is ReturnType.ERROR
    assert robot.set_gripper('ring_b', close=True).ok
    refused = robot.set_gripper('ring_a', close=False)   # ring_b is still closing
    assert refused.code is ReturnType.ERROR and 'ring_b is closing' in refused.message
    _, state = cycle(robot, n=90, t0=0.6)                # its close time (0.8 s)
    assert robot.set_gripper('ring_a', close=False).ok
    _, state = cycle(robot, n=60, t0=1.5)
    assert state.grippers == {'ring_a': False, 'ring_b': True}


def test_a_gripper_switches_in_its_time_and_the_support_follows_its_sensor():
    """The grippers' state switches once their YAML time passed (ring_b: open 0.5 s), and the
    efforts' support with it (ring_a until then)."""
    robot = active()
    cycle(robot)
    t0 = 0.01
    assert robot.set_gripper('ring_b', close=False).ok
    switched = None
    for k in range(1, 100):
        _, state = cycle(robot, t0=t0 + k * DT)
        if not state.grippers['ring_b']:
            switched = k * DT
            break
    assert switched == pytest.approx(POLE.motion_limits.grippers['ring_b'].open, abs=DT + 1e-9)
    assert robot.support.ring == 'ring_a'
    assert robot.set_gripper('ring_b', close=True).ok
    for k in range(1, 100):
        _, state = cycle(robot, t0=1.0 + k * DT)
        if state.grippers['ring_b']:
            break
    assert robot.set_gripper('ring_a', close=False).ok
    cycle(robot, n=60, t0=2.0)
    assert robot.support.ring == 'ring_b'


def test_an_actuator_fault_is_reported_for_that_actuator_and_the_robot_holds():
    robot = active()
    cycle(robot, Command(GOAL), n=3)  # moving
    robot.inject_fault(FaultKind.FOLLOWING_ERROR, 'leg_3', 'lag 5 mm')
    result, state = cycle(robot, Command(GOAL))
    assert result.code is ReturnType.ERROR and 'leg_3: following_error (lag 5 mm)' in result.message
    assert state.faults == (ActuatorFault('leg_3', FaultKind.FOLLOWING_ERROR, 'lag 5 mm'),)
    assert [a.fault is not None for a in state.actuators] == [False, False, True, False, False, False]
    assert not any(a.enabled for a in state.actuators)
    held = state.positions
    assert not np.allclose(held, GOAL) and not np.allclose(held, POLE.home_lengths)
    _, state = cycle(robot, Command(GOAL), n=50)
    np.testing.assert_array_equal(state.positions, held)
    np.testing.assert_array_equal(state.targets, held)
    assert robot.set_gripper('ring_b', close=False).code is ReturnType.ERROR


def test_a_faulted_robot_is_not_enabled_again_without_a_reset():
    robot = active()
    robot.inject_fault(FaultKind.DRIVE_FAULT, 'leg_5')
    refused = robot.on_activate()
    assert refused.code is CallbackReturn.FAILURE and 'leg_5: drive_fault' in refused.reason
    assert robot.on_deactivate().ok and robot.on_activate().code is CallbackReturn.FAILURE
    _, state = cycle(robot, Command(GOAL), n=20)
    np.testing.assert_array_equal(state.positions, POLE.home_lengths)
    reset = robot.reset_faults()
    assert reset.ok and 'leg_5' in reset.message
    result, state = cycle(robot, Command(GOAL), n=20)  # reset, not enabled: still nothing moves
    assert result.code is ReturnType.ERROR and state.faults == ()
    np.testing.assert_array_equal(state.positions, POLE.home_lengths)
    assert robot.on_activate().ok
    result, state = cycle(robot, Command(GOAL), n=20)
    assert result.ok and not np.array_equal(state.positions, POLE.home_lengths)


def test_a_lost_bus_faults_every_actuator_and_blocks_the_reset_until_it_returns():
    robot = active(FRAME)
    robot.inject_fault(FaultKind.BUS_LOST)
    state = robot.read(0.0, DT)
    assert state.bus is BusState.LOST
    assert {f.kind for f in state.faults} == {FaultKind.BUS_LOST} and len(state.faults) == 8
    assert robot.reset_faults().code is ReturnType.ERROR
    robot.restore_bus()
    assert robot.read(0.0, DT).bus is BusState.OPERATIONAL and robot.on_activate().code is CallbackReturn.FAILURE
    assert robot.reset_faults().ok and robot.on_activate().ok


def test_stuck_legs_and_sensor_faults_as_run_time_parameters():
    robot = active(fault_seed=3)
    assert robot.set_parameters({'stuck_legs': [2, 5]}).ok
    _, state = cycle(robot, Command(GOAL), n=200)
    np.testing.assert_array_equal(state.positions[[1, 4]], POLE.home_lengths[[1, 4]])
    np.testing.assert_array_equal(state.positions[[0, 2, 3, 5]], GOAL[[0, 2, 3, 5]])
    assert [a.target_reached for a in state.actuators] == [True, False, True, True, False, True]
    assert robot.set_parameters({'stuck_legs': [7]}).code is ReturnType.ERROR
    assert robot.set_parameters({'kp': 1.0}).code is ReturnType.ERROR  # not settable at run time
    assert robot.set_parameters({'sensor_noise': 1e-3}).ok
    noisy = np.array([robot.read(0.0, DT).positions for _ in range(500)]) - state.positions
    assert 0.8e-3 < np.std(noisy) < 1.2e-3
    assert robot.set_parameters({'drop_probability': 1.0}).ok
    before = robot.read(0.0, DT)  # lost: the previous sample
    robot.set_gripper('ring_b', close=False)
    later = robot.grippers.now + 1.0
    robot.write(later, DT, None)  # ring_b's open time (0.5 s) passed
    lost = robot.read(later, DT)
    assert lost.lost and np.array_equal(lost.positions, before.positions)
    assert lost.grippers == {'ring_a': True, 'ring_b': False}  # the grippers are read on their own


@pytest.mark.parametrize('parameters, reason', [
    ({'initial_lengths': (0.4,) * 5}, 'initial_lengths must be 6'),
    ({'initial_lengths': (0.2,) * 6}, 'outside the stroke'),
    ({'mode': 'fast'}, 'mode must be one of'),
    ({'kp': -1.0}, 'kp must be in'),
])
def test_a_bad_configuration_is_a_failed_transition(parameters, reason):
    outcome = SimulatedRobot().on_configure(HardwareConfig(POLE, parameters))
    assert outcome.code is CallbackReturn.FAILURE and reason in outcome.reason


def test_the_robot_stays_where_it_is_across_cleanup_and_configure():
    robot = active()
    _, state = cycle(robot, Command(GOAL), n=5)
    assert robot.on_deactivate().ok and robot.on_cleanup().ok
    assert robot.on_configure(HardwareConfig(POLE, IDEAL)).ok
    np.testing.assert_array_equal(robot.read(0.0, DT).positions, state.positions)


def test_the_physical_state_survives_the_driver(tmp_path):
    path = tmp_path / 'robot.json'
    robot = active(FRAME, state_file=str(path))
    rings = np.array([0.0, 0.2])
    _, state = cycle(robot, Command(FRAME.home_lengths + 0.004, rings), n=100)
    assert robot.set_gripper('ring_a', close=False).ok
    cycle(robot, n=100, t0=1.0)    # ring_a's open time (0.8 s, the YAML's) passed
    assert robot.on_shutdown().ok and robot.on_shutdown().ok  # twice: nothing more to do
    saved = load_state(path, FRAME, 2)
    np.testing.assert_allclose(saved.lengths, state.positions, atol=1e-6)
    np.testing.assert_allclose(saved.rings, rings, atol=1e-6)
    assert saved.grippers == {'ring_a': False, 'ring_b': True}
    again = configured(FRAME, state_file=str(path), initial_lengths=tuple(FRAME.home_lengths))  # the file wins
    resumed = again.read(0.0, DT)
    np.testing.assert_allclose(resumed.positions, state.positions, atol=1e-6)
    np.testing.assert_allclose(resumed.ring_positions, rings, atol=1e-6)
    assert resumed.grippers == {'ring_a': False, 'ring_b': True} and not any(a.enabled for a in resumed.actuators)
    again.on_shutdown()
    other = SimulatedRobot().on_configure(HardwareConfig(POLE, {'state_file': str(path)}))
    assert other.code is CallbackReturn.FAILURE and 'frame_climber' in other.reason


def test_the_driver_checks_a_command_against_the_stroke_and_the_ring_ranges():
    command = checked_command(FRAME, FRAME.home_lengths, {'ring_b_rotation': 0.1}, [0.05, 0.0])
    np.testing.assert_array_equal(command.rings, [0.05, 0.1])  # ring_a keeps its target
    assert checked_command(POLE, GOAL, {}, []).rings is None
    too_long = np.array(POLE.home_lengths)
    too_long[3] = POLE.max_length + 1e-6
    with pytest.raises(RejectedCommand, match=r"\['leg_4'\] outside the stroke"):
        checked_command(POLE, too_long, {}, [])
    with pytest.raises(RejectedCommand, match='ring rotations'):
        checked_command(FRAME, FRAME.home_lengths, {'ring_a_rotation': np.nan}, [0.0, 0.0])
