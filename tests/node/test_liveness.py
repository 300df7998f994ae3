"""Liveness: nothing commands motion on stale information.

Pure mapping checks (state timeout, the operator's round trip, the driver's activity) and the
climb node in-process: a step pauses when the robot's state or the operator station goes
silent, brakes along its path, holds without gripper switches, and resumes only on ``climb/resume``.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from rrps_climbing.nodes.climb_node import ClimbNode
from rrps_climbing.path_brake import brake_time
from rrps_description.geometry import load_robot
from rrps_description.motion_limits import stream_limits
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_interfaces.climb import ClimbState, ClimbStatus, PauseReason
from rrps_interfaces.teleop import TeleopCode, TeleopStatus
from rrps_kinematics.nodes.fk_node import FkNode
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_teleop.mapping import TeleopConfig, TeleopMapping
from rrps_testing.ros_harness import Probe, Spinner, wait_for

POLE = load_robot('pole_climber')
LEG_STREAM = stream_limits(POLE.motion_limits.legs)
BRAKE = brake_time(LEG_STREAM)   # a paused climb's brake along its path [s]
MASTER = load_robot('master_robot')
DEADLINE = 40.0


def _engaged_mapping(**config) -> TeleopMapping:
    m = TeleopMapping(POLE, TeleopConfig(**config))
    m.on_enable(0.0, True)
    m.on_master_pose(0.0, MASTER.home_position, MASTER.home_quaternion_xyzw)
    m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw, t=0.0)
    assert m.step(0.01).engaged
    return m


def test_a_stale_slave_pose_holds_the_robot():
    m = _engaged_mapping(state_timeout=0.2)
    m.on_enable(0.25, True)
    m.on_master_pose(0.25, MASTER.home_position + [0, 0, 0.001], MASTER.home_quaternion_xyzw)
    out = m.step(0.25)
    assert out.code == TeleopCode.SLAVE_STATE_LOST and not out.has_command and not m.engaged
    m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw, t=0.26)
    assert m.step(0.26).engaged  # a fresh state: engaging again is a clutch


def test_the_round_trip_scales_the_speed_down_then_holds():
    m = _engaged_mapping()
    assert m.speed_factor(0.01) == 1.0
    m.on_round_trip(0.02, 0.25)
    assert m.speed_factor(0.02) == pytest.approx(1.0 - 0.75 * 0.5)
    target = MASTER.home_position + [0.0, 0.0, 0.01]     # far: speed limited every step
    slow = []
    for k in range(1, 6):
        t = 0.02 + 0.02 * k
        m.on_enable(t, True)
        m.on_master_pose(t, target, MASTER.home_quaternion_xyzw)
        m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw, t=t)
        m.on_round_trip(t, 0.25)
        out = m.step(t)
        slow.append(out.position)
        assert out.code == TeleopCode.LATENCY_SLOWED
    steps = np.linalg.norm(np.diff(slow, axis=0), axis=1)
    assert np.all(steps <= 0.625 * m.config.max_linear_speed * 0.02 + 1e-12)
    m.on_round_trip(0.2, 0.35)
    m.on_enable(0.2, True)
    m.on_master_pose(0.2, target, MASTER.home_quaternion_xyzw)
    m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw, t=0.2)
    out = m.step(0.2)
    assert out.code == TeleopCode.LINK_LATENCY and not out.has_command
    m.on_round_trip(0.21, float('inf'))                   # no answer at all
    assert m.check(0.21)[0] == TeleopCode.LINK_LATENCY
    assert m.round_trip(2.0) is None                      # an old measurement does not count


def test_an_inactive_driver_blocks_engaging():
    m = _engaged_mapping()
    m.set_driver_active(False)
    m.on_enable(0.02, True)
    m.on_master_pose(0.02, MASTER.home_position, MASTER.home_quaternion_xyzw)
    assert m.step(0.02).code == TeleopCode.DRIVER_INACTIVE
    with pytest.raises(ValueError, match='slow_latency'):
        TeleopConfig(slow_latency=0.4, hold_latency=0.3)


def test_after_the_slave_state_was_lost_engaging_waits_for_the_drivers_next_status():
    """A driver that died and restarted is inactive, and its state may come back before its
    status does: the dead driver's 'active' must not let teleop engage meanwhile."""
    m = _engaged_mapping(state_timeout=0.2)
    m.set_driver_active(True)

    def step(t: float):
        m.on_enable(t, True)
        m.on_master_pose(t, MASTER.home_position, MASTER.home_quaternion_xyzw)
        return m.step(t)
    assert step(0.05).engaged
    assert step(0.3).code == TeleopCode.SLAVE_STATE_LOST       # the driver died
    m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw, t=0.5)  # restarted
    out = step(0.5)
    assert out.code == TeleopCode.DRIVER_INACTIVE and not out.engaged and not out.has_command
    m.set_driver_active(False)                                  # its first status
    assert step(0.52).code == TeleopCode.DRIVER_INACTIVE
    m.set_driver_active(True)                                   # the operator activated it
    assert step(0.54).engaged
    # a mapping that never heard of a driver (no driver status at all) is not held up
    m = _engaged_mapping(state_timeout=0.2)
    assert step(0.3).code == TeleopCode.SLAVE_STATE_LOST
    m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw, t=0.5)
    assert step(0.5).engaged


def _status(msgs) -> ClimbStatus | None:
    return ClimbStatus.from_key_values(msgs[-1].values) if msgs else None


def _teleop_values() -> list:
    values = TeleopStatus(code=TeleopCode.DEADMAN_RELEASED, engaged=False).to_values()
    return [KeyValue(key=k, value=v) for k, v in values.items()]


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize('fault', ['operator', 'state'])
def test_a_climb_pauses_on_lost_link_or_state_and_resumes_only_on_request(ros_context, fault):
    robot = Parameter('robot', value='pole_climber')
    driver = DriverNode(context=ros_context, parameter_overrides=[
        robot, Parameter('rate', value=100.0), Parameter('auto_activate', value=True)])
    climb = ClimbNode(context=ros_context, parameter_overrides=[
        robot, Parameter('speed', value=0.02), Parameter('step_length', value=0.06),
        Parameter('start', value=0.2)])
    nodes = [driver, IkNode(context=ros_context, parameter_overrides=[robot]),
             FkNode(context=ros_context, parameter_overrides=[robot]), climb]
    probe = Probe(context=ros_context)
    status = probe.collect(DiagnosticStatus, 'climb/status')
    grippers = probe.collect(JointState, 'grippers/state', stamped=True)
    poses = probe.collect(PoseStamped, 'pose', stamped=True)
    teleop = probe.publisher(DiagnosticStatus, 'teleop/status')
    station = {'on': True}
    probe.create_timer(0.1, lambda: station['on'] and teleop.publish(
        DiagnosticStatus(name='teleop_node', values=_teleop_values())))
    up = probe.create_client(Trigger, 'climb/step_up')
    resume = probe.create_client(Trigger, 'climb/resume')

    def call(client):
        future = client.call_async(Trigger.Request())
        assert wait_for(future.done, DEADLINE)
        return future.result()

    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(lambda: climb.pose is not None and climb.watch.operator_seen(),
                        DEADLINE)
        assert wait_for(lambda: call(up).success, DEADLINE)
        # fault in the middle of ring_b's motion
        assert wait_for(lambda: (s := _status(status)) is not None and s.phase == 'move_b', DEADLINE)
        if fault == 'operator':
            station['on'] = False            # the operator station falls silent (link down)
        else:
            driver.set_parameters([Parameter('drop_probability', value=1.0)])  # no state
        expected = (PauseReason.OPERATOR_LINK_LOST if fault == 'operator'
                    else PauseReason.ROBOT_STATE_LOST)
        assert wait_for(lambda: (s := _status(status)) is not None and s.state is ClimbState.PAUSED,
                        DEADLINE)
        paused = _status(status)
        assert paused.pause_reason is expected and paused.phase == 'move_b'
        t_pause = time.monotonic()
        n_grip = len(grippers)
        at_pause = driver.reference.copy()
        # the climb brakes along its path (a brake's time), then holds: the reference stays
        last = [at_pause, t_pause]

        def braked() -> bool:
            if not np.array_equal(driver.reference, last[0]):
                last[:] = [driver.reference.copy(), time.monotonic()]
            return time.monotonic() - last[1] > 0.3 and time.monotonic() > t_pause + BRAKE
        assert wait_for(braked, DEADLINE)
        reference = driver.reference.copy()
        # at most the leg stream's speed for half a brake on (its path time goes on half its duration)
        assert np.max(np.abs(reference - at_pause)) <= LEG_STREAM.speed * BRAKE / 2 + 1e-9
        wait_for(lambda: False, timeout=1.0)  # at least 1 s paused
        # held: the driver's reference did not move, no gripper switched, still paused
        np.testing.assert_allclose(driver.reference, reference, atol=1e-12)
        assert all(list(m.position) == list(grippers[n_grip - 1][1].position)
                   for _, m in grippers[n_grip:])
        assert _status(status).state is ClimbState.PAUSED
        # the cause goes away: still paused until the operator resumes
        station['on'] = True
        driver.set_parameters([Parameter('drop_probability', value=0.0)])
        wait_for(lambda: False, timeout=1.0)
        assert _status(status).state is ClimbState.PAUSED
        np.testing.assert_allclose(driver.reference, reference, atol=1e-12)
        assert any(t > t_pause for t, _ in poses)
        # resumed (again if a stall of this loaded process aged an input just then: refused, still paused)
        replies = []
        assert wait_for(lambda: replies.append(call(resume)) or replies[-1].success, DEADLINE, period=0.2), \
            replies[-1].message
        assert all('refused: robot state lost' in r.message for r in replies[:-1]), replies

        def finished() -> bool:
            # an operator resumes again after any later pause (a loaded machine can delay the
            # state past state_timeout: pausing is the safe side); the step must complete
            if _status(status).state is ClimbState.PAUSED:
                call(resume)
            return _status(status).state is ClimbState.IDLE
        assert wait_for(finished, DEADLINE, period=0.2), _status(status)
    assert not any(ClimbStatus.from_key_values(s.values).state is ClimbState.FAILED for s in status)
