"""climb_node over ROS, launch-free: a climb executed on the driver through IK and FK.

Tolerance of "ends where the plan says": the node switches a gripper only once the measured pose
has stayed within ``position_tolerance`` (1 mm) and ``orientation_tolerance`` of the planned one
for ``settle_time``. The world odometry is chained from the measured pose at every gripper
hand-over, so its error is at most one tolerance per hand-over (the bound asserted; measured
< 1e-3 mm after a 4-step run of this stack: the kinematic driver settles well inside it); the kinematic pose
a_T_b itself ends within one tolerance of the plan.
"""

from __future__ import annotations

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from rrps_climbing.gait import GaitPlanner
from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.structures import make_structure
from rrps_interfaces.climb import ClimbPreview, ClimbState, ClimbStatus, PreviewLimit, StepRefusal
from rrps_interfaces.teleop import TeleopCode, TeleopStatus
from rrps_kinematics import inverse_kinematics
from rrps_runtime.messages import pose_from_msg
from rrps_testing.climb_stack import climb_stack
from rrps_testing.ros_harness import DEADLINE, Probe, Spinner, header_time, wait_for

pytestmark = pytest.mark.ros

TOL = 0.001  # position_tolerance of the node [m]


def _stack(ctx, robot='pole_climber', driver=None, **climb):
    """Driver, IK, FK and climb_node in this test's process (rrps_testing.climb_stack). These
    tests check where a climb goes; its pauses on stale inputs are tested in test_liveness.py and
    test_multihost.py."""
    return climb_stack(ctx, robot, driver=driver, climb={
        'structure': 'pole', 'speed': 0.05, 'step_length': 0.06, 'position_tolerance': TOL, 'start': 0.2,
        **climb})


def _teleop_status(code, *, engaged: bool) -> DiagnosticStatus:
    """A teleop/status as the teleop node writes it (the typed contract)."""
    values = TeleopStatus(code=code, engaged=engaged).to_values()
    return DiagnosticStatus(message=code.name, values=[KeyValue(key=k, value=v) for k, v in values.items()])


def _values(status: DiagnosticStatus) -> dict:
    return {kv.key: kv.value for kv in status.values}


def _idle_after(statuses, steps_done: int):
    return any(s.message == 'idle' and _values(s)['steps_done'] == str(steps_done) for s in statuses)


def _at_rest_after(probe, odo_a, odo_b, poses=None):
    """Wait for the odometry of both rings (and the measured pose) of one pose measured after
    now, e.g. after the climb went idle: (odo_a, odo_b, pose) with one stamp, pose None without
    ``poses``. climb_node publishes the odometry with the stamp of the pose it chained."""
    t = probe.now()

    def found():
        b = {header_time(m): m for m in list(odo_b)}
        p = {header_time(m): m for m in list(poses)} if poses is not None else None
        for a in reversed(list(odo_a)):
            stamp = header_time(a)
            if stamp <= t:
                return None
            if stamp in b and (p is None or stamp in p):
                return a, b[stamp], None if p is None else p[stamp]
        return None
    assert wait_for(found)
    return found()


@pytest.mark.slow
def test_scripted_climb_ends_where_the_plan_says(ros_context):
    steps = 2
    probe = Probe(context=ros_context)
    status = probe.collect(DiagnosticStatus, 'climb/status')
    grippers = probe.collect(JointState, 'grippers/state')
    odo_a = probe.collect(PoseStamped, 'odometry/ring_a')
    odo_b = probe.collect(PoseStamped, 'odometry/ring_b')
    poses = probe.collect(PoseStamped, 'pose')
    previews = probe.collect(DiagnosticStatus, 'climb/preview')
    nodes = _stack(ros_context, auto_steps=steps)
    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(lambda: _idle_after(status, steps)), \
            [(s.message, _values(s)['detail']) for s in status[-3:]]
        final_a, final_b, final_pose = _at_rest_after(probe, odo_a, odo_b, poses)
    assert not any(s.message == 'error' for s in status)
    phases = [ClimbStatus.from_key_values(s.values).phase for s in status if s.message == 'executing']
    assert {'release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a'} <= set(phases)
    # the climb was previewed once, accepted, before it executed
    assert len(previews) == 1 and ClimbStatus.from_key_values(status[0].values).previewing
    preview = ClimbPreview.from_key_values(previews[0].values)
    assert preview.accepted and 0.0 < preview.peak_force < nodes[0].geometry.max_force
    assert 0.0 < preview.min_margin < 1.0 and preview.simulated > 2 * steps * 0.06 / 0.05

    # The interlock in the observed gripper stream: never both open; ring_a opened once per step.
    closed = np.array([[p > 0.5 for p in dict(zip(m.name, m.position)).values()] for m in grippers])
    assert len(closed) > 10 and np.all(closed.any(axis=1))
    openings_a = np.sum(closed[:-1, 0] & ~closed[1:, 0])
    assert openings_a == steps

    # The plan the node executed: from the home pose at s=0.2, two steps of 60 mm.
    planner = GaitPlanner(nodes[0].geometry, make_structure('pole'))
    plan = planner.plan(steps * 0.06, steps, start=0.2)
    final = plan.phases[-1]
    handovers = sum(1 for a, b in zip(plan.phases[:-1], plan.phases[1:])
                    if (a.gripper_a, a.gripper_b) != (b.gripper_a, b.gripper_b))
    p, q = pose_from_msg(final_pose)
    assert np.linalg.norm(p - final.a_T_b.position) <= TOL
    pa, _ = pose_from_msg(final_a)
    pb, _ = pose_from_msg(final_b)
    assert final_a.header.frame_id == 'odom'
    assert np.linalg.norm(pa - final.world_T_a.position) <= handovers * TOL
    assert np.linalg.norm(pb - final.world_T_b.position) <= handovers * TOL
    assert pa[2] == pytest.approx(0.2 + steps * 0.06, abs=handovers * TOL)
    # odometry is consistent with the measured kinematics (of the same pose, by its stamp):
    # world_T_b = world_T_a · a_T_b
    assert np.allclose((Pose(*pose_from_msg(final_a)) @ Pose(p, q)).matrix,
                       Pose(*pose_from_msg(final_b)).matrix, atol=1e-6)


def _call(probe, client):
    assert client.wait_for_service(timeout_sec=DEADLINE)
    future = client.call_async(Trigger.Request())
    assert wait_for(future.done)
    return future.result()


@pytest.mark.slow
def test_step_services_teleop_refusal_and_plan_refusal(ros_context):
    probe = Probe(context=ros_context)
    status = probe.collect(DiagnosticStatus, 'climb/status')
    odo_a = probe.collect(PoseStamped, 'odometry/ring_a')
    odo_b = probe.collect(PoseStamped, 'odometry/ring_b')
    teleop = probe.publisher(DiagnosticStatus, 'teleop/status')
    teleop_seen = probe.collect(DiagnosticStatus, 'teleop/status')
    up = probe.create_client(Trigger, 'climb/step_up')
    down = probe.create_client(Trigger, 'climb/step_down')
    # an operator station on the line: its teleop/status at 10 Hz, as the teleop node sends it
    station = {'status': _teleop_status(TeleopCode.NO_WARNING, engaged=True)}
    probe.create_timer(0.1, lambda: teleop.publish(station['status']))
    with Spinner(ros_context, _stack(ros_context) + [probe]):
        assert wait_for(lambda: odo_a)
        z0 = pose_from_msg(odo_a[-1])[0][2]
        assert z0 == pytest.approx(0.2, abs=1e-6)
        # Teleoperation engaged: no step.
        assert wait_for(lambda: teleop.get_subscription_count() == 2)  # climb_node and the probe
        # Delivered: the probe, in climb_node's executor, has two more engaged statuses, so
        # climb_node's copy was queued before the service request that follows.
        n = len(teleop_seen)
        assert wait_for(lambda: len(teleop_seen) > n + 1)
        reply = _call(probe, up)
        assert not reply.success and 'teleoperation' in reply.message
        station['status'] = _teleop_status(TeleopCode.DEADMAN_RELEASED, engaged=False)
        assert wait_for(lambda: _call(probe, up).success)
        # the step is previewed (IDLE) before it executes
        executing = ClimbState.EXECUTING
        assert wait_for(lambda: status and ClimbStatus.from_key_values(status[-1].values).state is executing), \
            _values(status[-1])['detail']
        busy = _call(probe, up)
        assert not busy.success and 'executing' in busy.message
        assert wait_for(lambda: _idle_after(status, 1)), _values(status[-1])['detail']
        z_up = pose_from_msg(_at_rest_after(probe, odo_a, odo_b)[0])[0][2]
        assert z_up == pytest.approx(0.26, abs=3 * TOL)
        assert _call(probe, down).success
        assert wait_for(lambda: _idle_after(status, 2)), _values(status[-1])['detail']
        assert pose_from_msg(_at_rest_after(probe, odo_a, odo_b)[0])[0][2] == pytest.approx(0.2, abs=6 * TOL)
    assert not any(s.message == 'error' for s in status)


def test_a_step_beyond_the_stroke_is_refused_with_the_limit(ros_context):
    probe = Probe(context=ros_context)
    odo_a = probe.collect(PoseStamped, 'odometry/ring_a')
    status = probe.collect(DiagnosticStatus, 'climb/status')
    up = probe.create_client(Trigger, 'climb/step_up')
    with Spinner(ros_context, _stack(ros_context, step_length=0.6) + [probe]):
        assert wait_for(lambda: odo_a)
        reply = _call(probe, up)
        assert wait_for(lambda: any(_values(s)['detail'].startswith('plan refused') for s in status))
    assert not reply.success and 'stroke' in reply.message and 'leg_' in reply.message
    assert status[-1].message == 'idle' and status[-1].level == DiagnosticStatus.WARN


def test_a_robot_moved_off_the_gait_is_brought_back_first(ros_context):
    """The driver starts 15 mm off the gait (as after teleoperation): ring_b re-grips first."""
    g = load_robot('pole_climber')
    off = inverse_kinematics(g, g.home_position + [0.015, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]).lengths
    nodes = _stack(ros_context, auto_steps=1, step_length=0.04,
                   driver={'initial_lengths': [float(v) for v in off]})
    probe = Probe(context=ros_context)
    status = probe.collect(DiagnosticStatus, 'climb/status')
    poses = probe.collect(PoseStamped, 'pose')
    odo_a = probe.collect(PoseStamped, 'odometry/ring_a')
    odo_b = probe.collect(PoseStamped, 'odometry/ring_b')
    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(lambda: _idle_after(status, 1)), status[-1:]
        final_a, _, final_pose = _at_rest_after(probe, odo_a, odo_b, poses)
    phases = [ClimbStatus.from_key_values(s.values).phase for s in status if s.message == 'executing']
    # the status is republished while a phase lasts: the order of the phases, each once
    phases = [phase for i, phase in enumerate(phases) if i == 0 or phase != phases[i - 1]]
    assert phases[:2] == ['release_b', 'move_b']
    plan = GaitPlanner(g, make_structure('pole')).plan(0.04, 1, start=0.2)
    p, _ = pose_from_msg(final_pose)
    assert np.linalg.norm(p - plan.phases[-1].a_T_b.position) <= TOL
    assert pose_from_msg(final_a)[0][2] == pytest.approx(0.24, abs=4 * TOL)


def test_a_step_whose_preview_breaks_a_limit_is_refused_and_the_robot_holds(ros_context):
    """A holding margin of 0.99 asked of the preview: every step breaks it, and none starts."""
    probe = Probe(context=ros_context)
    status = probe.collect(DiagnosticStatus, 'climb/status')
    previews = probe.collect(DiagnosticStatus, 'climb/preview')
    grippers = probe.collect(JointState, 'grippers/state')
    odo_a = probe.collect(PoseStamped, 'odometry/ring_a')
    up = probe.create_client(Trigger, 'climb/step_up')
    with Spinner(ros_context, _stack(ros_context, preview_min_margin=0.99) + [probe]):
        assert wait_for(lambda: odo_a)
        reply = _call(probe, up)
        assert wait_for(lambda: any(_values(s)['refusal'] == 'PREVIEW_LIMIT' for s in status))
        assert wait_for(lambda: previews)
        z = pose_from_msg(odo_a[-1])[0][2]
    assert reply.success and reply.message.startswith('previewing 1 step(s)')
    preview = ClimbPreview.from_key_values(previews[-1].values)
    assert not preview.accepted and preview.limit is PreviewLimit.HOLDING and preview.min_margin < 0.99
    assert previews[-1].level == DiagnosticStatus.WARN
    states = [ClimbStatus.from_key_values(s.values) for s in status]
    assert any(s.previewing for s in states) and all(s.state is ClimbState.IDLE for s in states)
    assert states[-1].refusal is StepRefusal.PREVIEW_LIMIT and 'holding: ' in states[-1].detail
    assert status[-1].level == DiagnosticStatus.WARN
    assert all(min(m.position) > 0.5 for m in grippers)                  # no gripper opened
    assert z == pytest.approx(0.2, abs=1e-6)
