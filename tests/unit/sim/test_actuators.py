"""Actuator models of the simulated driver: lag, speed and stroke limits, PD on the dynamics, faults."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_kinematics import inverse_kinematics
from rrps_loads.statics import holding_forces
from rrps_sim.actuators import DynamicActuators, QuasiStaticEfforts, SensorFaults
from rrps_sim.kinematic_actuators import KinematicActuators

LO, HI = 0.3, 0.55


def kinematic(time_constant=0.0, max_speed=math.inf, initial=0.4):
    return KinematicActuators(LO, HI, max_speed, time_constant, np.full(6, initial))


def test_no_lag_no_speed_limit_reaches_the_reference_at_once():
    act = kinematic()
    ref = np.linspace(0.35, 0.5, 6)
    act.step(ref, 0.002)
    np.testing.assert_array_equal(act.positions, ref)
    np.testing.assert_allclose(act.velocities, (ref - 0.4) / 0.002)
    act.step(ref, 0.0)  # a zero step (command published at once) is well defined
    np.testing.assert_array_equal(act.positions, ref)
    np.testing.assert_array_equal(act.velocities, np.zeros(6))


def test_first_order_lag_matches_the_exponential():
    tau, dt, n = 0.05, 0.002, 40
    act = kinematic(time_constant=tau)
    ref = np.full(6, 0.5)
    for _ in range(n):
        act.step(ref, dt)
    expected = 0.5 + (0.4 - 0.5) * math.exp(-n * dt / tau)
    np.testing.assert_allclose(act.positions, expected, rtol=0, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(ref=st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6),
       dt=st.floats(1e-4, 0.05), tau=st.floats(0.0, 0.2))
def test_speed_and_stroke_limits_hold_for_any_reference(ref, dt, tau):
    act = kinematic(time_constant=tau, max_speed=0.05)
    before = act.positions.copy()
    act.step(np.array(ref), dt)
    assert np.all(np.abs(act.positions - before) <= 0.05 * dt + 1e-15)
    assert np.all(np.abs(act.velocities) <= 0.05 + 1e-9)
    assert np.all((act.positions >= LO) & (act.positions <= HI))


def test_reference_outside_the_stroke_stops_at_the_end_stop():
    act = kinematic()
    act.step(np.array([0.0, 1.0, 0.4, 0.4, 0.4, 0.4]), 0.01)
    np.testing.assert_array_equal(act.positions[:2], [LO, HI])


def test_stuck_actuator_ignores_commands():
    act = kinematic(max_speed=0.05)
    act.stuck[2] = True
    for _ in range(100):
        act.step(np.full(6, 0.5), 0.01)
    assert act.positions[2] == 0.4 and act.velocities[2] == 0.0
    np.testing.assert_allclose(np.delete(act.positions, 2), 0.45)


@pytest.mark.parametrize('kwargs, message', [
    (dict(initial=np.full(6, 0.2)), 'outside'),
    (dict(time_constant=-1.0), 'time_constant'),
    (dict(max_speed=0.0), 'max_speed'),
    (dict(initial=np.array([0.4, np.nan, 0.4, 0.4, 0.4, 0.4])), 'finite'),
])
def test_invalid_models_are_refused(kwargs, message):
    args = dict(min_position=LO, max_position=HI, max_speed=1.0, time_constant=0.0, initial=np.full(6, 0.4))
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        KinematicActuators(**args)


@pytest.mark.parametrize('ref, dt', [(np.full(5, 0.4), 0.01), (np.full(6, np.nan), 0.01),
                                     (np.full(6, 0.4), -0.01), (np.full(6, 0.4), math.inf)])
def test_invalid_steps_raise_and_leave_the_state(ref, dt):
    act = kinematic()
    with pytest.raises(ValueError):
        act.step(ref, dt)
    np.testing.assert_array_equal(act.positions, np.full(6, 0.4))


@pytest.fixture(scope='module')
def robot():
    return load_robot('pole_climber')


def test_dynamic_actuators_hold_the_home_pose_with_the_holding_forces(robot):
    dyn = DynamicActuators(robot, robot.home_lengths)
    for _ in range(150):
        dyn.step(robot.home_lengths, 0.002)
    np.testing.assert_allclose(dyn.positions, robot.home_lengths, atol=1e-7)
    np.testing.assert_allclose(dyn.efforts, holding_forces(robot, robot.home_position,
                                                           robot.home_quaternion_xyzw), rtol=1e-3)


def test_dynamic_actuators_track_a_new_pose_within_the_speed_limit(robot):
    target = inverse_kinematics(robot, robot.home_position + [0.01, -0.005, 0.01],
                                robot.home_quaternion_xyzw).lengths
    dyn = DynamicActuators(robot, robot.home_lengths, time_constant=0.02)
    peak = 0.0
    for _ in range(400):  # 0.8 s: the 0.05 m/s reference needs about 0.3 s
        dyn.step(target, 0.002)
        peak = max(peak, float(np.max(np.abs(dyn.velocities))))
    # max_speed shapes the reference; catching up its start, the PD loop overshoots by < 25 %
    assert 0.9 * robot.max_speed < peak < 1.25 * robot.max_speed
    np.testing.assert_allclose(dyn.positions, target, atol=1e-6)
    np.testing.assert_allclose(dyn.dynamics.position, robot.home_position + [0.01, -0.005, 0.01], atol=1e-5)


def test_dynamic_forces_saturate_at_max_force(robot):
    weak = robot.with_(max_force=20.0)  # holding needs about 16 N a leg
    target = inverse_kinematics(weak, weak.home_position + [0.0, 0.0, 0.02], weak.home_quaternion_xyzw).lengths
    dyn = DynamicActuators(weak, weak.home_lengths, time_constant=0.0, max_speed=math.inf)
    peak = 0.0
    for _ in range(50):
        dyn.step(target, 0.002)
        peak = max(peak, float(np.max(np.abs(dyn.efforts))))
    assert peak == pytest.approx(20.0)


def test_dynamic_stuck_leg_keeps_its_length(robot):
    target = inverse_kinematics(robot, robot.home_position + [0.0, 0.0, 0.01], robot.home_quaternion_xyzw).lengths
    dyn = DynamicActuators(robot, robot.home_lengths)
    dyn.stuck = [False, False, False, True, False, False]
    for _ in range(300):
        dyn.step(target, 0.002)
    assert abs(dyn.positions[3] - robot.home_lengths[3]) < 1e-4
    assert np.all(np.abs(np.delete(dyn.positions - target, 3)) < 2e-3)


def test_sensor_faults_are_seeded_and_have_their_statistics():
    a = SensorFaults(noise=1e-3, drop_probability=0.25, seed=7)
    b = SensorFaults(noise=1e-3, drop_probability=0.25, seed=7)
    x = np.zeros((4000, 6))
    na, nb = a.measure(x), b.measure(x)
    np.testing.assert_array_equal(na, nb)
    assert np.std(na) == pytest.approx(1e-3, rel=0.05)
    drops = sum(a.drop() for _ in range(4000))
    assert drops / 4000 == pytest.approx(0.25, abs=0.03)
    clean = SensorFaults()
    assert clean.measure(x) is x and not any(clean.drop() for _ in range(100))
    with pytest.raises(ValueError):
        SensorFaults(noise=-1.0)
    with pytest.raises(ValueError):
        SensorFaults(drop_probability=1.5)


def test_quasi_static_efforts_hold_the_pose_and_refresh_on_period():
    robot = load_robot('pole_climber')
    home = robot.home_lengths
    efforts = QuasiStaticEfforts(robot, home, period=0.05)  # a short period keeps the test quick
    np.testing.assert_allclose(efforts.efforts, holding_forces(robot, robot.home_position,
                                                               robot.home_quaternion_xyzw), rtol=1e-9)
    raised = inverse_kinematics(robot, robot.home_position + [0.0, 0.0, 0.05], [0, 0, 0, 1]).lengths
    before = efforts.efforts.copy()
    np.testing.assert_array_equal(efforts.update(raised, 0.02), before)      # not yet due
    after = efforts.update(raised, 0.04)                                      # 0.06 s >= period
    np.testing.assert_allclose(after, holding_forces(robot, robot.home_position + [0.0, 0.0, 0.05],
                                                     [0, 0, 0, 1]), rtol=1e-9)
    assert not np.allclose(after, before)
