"""The climbing step through its action client (rrps_msgs/action/ClimbStep on climb/step), with
driver, IK, FK and climb_node in-process: a goal during teleoperation is refused with the reason
and nothing moves; a step's feedback (state, phase, progress, the preview's margins) arrives while
it runs and it succeeds one step up; a cancel in the middle of the step holds the robot where it
is, ring_b open and ring_a gripping (never both open), paused until climb/resume."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionClient
from sensor_msgs.msg import JointState

from rrps_interfaces.climb import ClimbState, ClimbStatus, PauseReason
from rrps_interfaces.teleop import TeleopCode, TeleopStatus
from rrps_runtime.action_host import ActionHost
from rrps_runtime.messages import pose_from_msg, stamp_to_seconds
from rrps_testing.ci import require
from rrps_testing.climb_stack import climb_stack
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def _stack(ctx):
    return climb_stack(ctx, climb={'structure': 'pole', 'speed': 0.02, 'step_length': 0.06, 'start': 0.2})


def _teleop_status(engaged: bool) -> DiagnosticStatus:
    code = TeleopCode.NO_WARNING if engaged else TeleopCode.DEADMAN_RELEASED
    values = TeleopStatus(code=code, engaged=engaged).to_values()
    return DiagnosticStatus(message=code.name, values=[KeyValue(key=k, value=v) for k, v in values.items()])


class _Client:
    """The action client on a SingleThreadedExecutor of its own (rrps_runtime.action_host)."""

    def __init__(self, probe):
        from rrps_msgs.action import ClimbStep
        self.type = ClimbStep
        self.host = ActionHost(probe)
        self.client = ActionClient(self.host.node, ClimbStep, 'climb/step')
        self.feedback: list = []

    def send(self, direction: int):
        future = self.client.send_goal_async(self.type.Goal(direction=direction),
                                             feedback_callback=lambda m: self.feedback.append(m.feedback))
        assert wait_for(future.done)
        handle = future.result()
        assert handle.accepted
        return handle, handle.get_result_async()

    def close(self):
        self.client.destroy()
        self.host.close()


def _probe_and_client(ctx):
    require(importlib.util.find_spec('rrps_msgs') is not None, 'rrps_msgs is not built (./rrps builds it)')
    probe = Probe(context=ctx)
    return probe, _Client(probe)


def test_a_goal_during_teleop_is_refused_with_the_reason_then_a_step_runs_with_feedback(ros_context):
    probe, client = _probe_and_client(ros_context)
    poses = probe.collect(PoseStamped, 'pose')
    teleop = probe.publisher(DiagnosticStatus, 'teleop/status')
    seen = probe.collect(DiagnosticStatus, 'teleop/status')
    station = {'status': _teleop_status(True)}
    probe.create_timer(0.1, lambda: teleop.publish(station['status']))
    try:
        with Spinner(ros_context, _stack(ros_context) + [probe]):
            assert wait_for(lambda: poses and client.client.wait_for_server(timeout_sec=0.1))
            assert wait_for(lambda: teleop.get_subscription_count() == 2)
            n = len(seen)
            assert wait_for(lambda: len(seen) > n + 1)   # climb_node has the engaged status
            before = pose_from_msg(poses[-1])[0]
            handle, result = client.send(client.type.Goal.UP)
            assert wait_for(result.done)
            refused = result.result()
            assert refused.status == GoalStatus.STATUS_ABORTED and not refused.result.success
            assert 'teleoperation' in refused.result.message, refused.result.message
            np.testing.assert_allclose(pose_from_msg(poses[-1])[0], before, atol=1e-9)  # nothing moved
            station['status'] = _teleop_status(False)
            n = len(seen)
            assert wait_for(lambda: len(seen) > n + 1)
            handle, result = client.send(client.type.Goal.UP)
            assert wait_for(result.done, timeout=240.0)
            done = result.result()
    finally:
        client.close()
    assert done.status == GoalStatus.STATUS_SUCCEEDED and done.result.success, done.result.message
    assert done.result.steps_done == 1
    states = [f.state for f in client.feedback]
    phases = [f.phase for f in client.feedback if f.phase]
    assert 'previewing' in states and 'executing' in states
    assert {'release_b', 'move_b', 'release_a', 'move_a'} <= set(phases)
    progress = [f.progress for f in client.feedback if f.state == 'executing']
    assert progress == sorted(progress) and 0.0 <= progress[0] < 0.5 < progress[-1] <= 1.0
    executing = [f for f in client.feedback if f.state == 'executing']
    assert all(0.0 < f.force_margin < 1.0 for f in executing)       # the preview's peak force was within the limit
    assert all(math.isnan(f.holding_margin) or f.holding_margin > 0.0 for f in executing)


def test_a_cancel_mid_step_holds_the_robot_with_one_gripper_closed(ros_context):
    probe, client = _probe_and_client(ros_context)
    poses = probe.collect(PoseStamped, 'pose')
    grippers = probe.collect(JointState, 'grippers/state')
    status = probe.collect(DiagnosticStatus, 'climb/status')
    try:
        with Spinner(ros_context, _stack(ros_context) + [probe]):
            assert wait_for(lambda: poses and client.client.wait_for_server(timeout_sec=0.1))
            handle, result = client.send(client.type.Goal.UP)
            assert wait_for(lambda: any(f.phase == 'move_b' for f in client.feedback), timeout=240.0)
            moving = pose_from_msg(poses[-1])[0]
            assert wait_for(lambda: np.linalg.norm(pose_from_msg(poses[-1])[0] - moving) > 0.002)  # on its way
            handle.cancel_goal_async()
            assert wait_for(result.done)
            cancelled = result.result()
            held = ClimbStatus.from_key_values(status[-1].values)
            n, cancelled_at = len(poses), probe.now()

            def still(since: int) -> bool:  # the last 50 poses (0.25 s of the driver) within 0.1 mm
                last = np.array([pose_from_msg(m)[0] for m in poses[max(since, len(poses) - 50):]])
                return len(last) == 50 and np.ptp(last, axis=0).max() < 1e-4
            # the stop takes its time (the jerk-limited setpoints' stopping distance; longer wall
            # time on a loaded machine), then the robot stands still and holds for 1 s more
            assert wait_for(lambda: still(n), timeout=60.0)
            rest = len(poses)
            assert wait_for(lambda: len(poses) > rest + 200)   # 1 s of the driver at 200 Hz
            # the poses of states from the cancel's result on (a loaded probe receives older ones late)
            after = np.array([pose_from_msg(m)[0] for m in list(poses)
                              if stamp_to_seconds(m.header.stamp) >= cancelled_at])
            holding = np.array([pose_from_msg(m)[0] for m in poses[rest - 50:]])
    finally:
        client.close()
    assert cancelled.status == GoalStatus.STATUS_CANCELED and 'cancelled' in cancelled.result.message
    assert held.state is ClimbState.PAUSED and held.pause_reason is PauseReason.CANCELLED
    # the jerk-limited setpoints stop the robot within a few mm (the stop's distance), then it holds
    assert np.linalg.norm(after[-1] - after[0]) < 0.006
    assert np.ptp(holding, axis=0).max() < 1e-4
    closed = [dict(zip(m.name, m.position)) for m in grippers]
    assert all(g['ring_a'] > 0.5 or g['ring_b'] > 0.5 for g in closed)   # never both open
    assert closed[-1]['ring_a'] > 0.5 and closed[-1]['ring_b'] < 0.5    # ring_a grips, ring_b open where it stopped
