"""climb_node's nav_msgs/Odometry against the robot's motion in a climb, launch-free (driver, IK,
FK and climb_node in-process): ``<prefix>base_link`` in ``<prefix>odom``; where the climb ends
is where the gait planner (computed here, independently of the node) puts ring_a; the twist,
integrated over the climb in odom, is the base's displacement and never faster than the
driver lets a leg move it; the covariance is a covariance and grows with the hand-overs."""

from __future__ import annotations

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from nav_msgs.msg import Odometry

from rrps_climbing.gait import GaitPlanner
from rrps_description.pose import Pose
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_description.structures import make_structure
from rrps_runtime.messages import stamp_to_seconds
from rrps_testing.climb_stack import climb_stack
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TOL = 0.001     # the climb node's position_tolerance [m]: its odometry's error per hand-over
SPEED = 0.05    # [m/s] along the moving gripper's path


def _values(status: DiagnosticStatus) -> dict:
    return {kv.key: kv.value for kv in status.values}


def test_the_odometry_follows_the_climb(ros_context):
    nodes = climb_stack(ros_context, climb={
        'structure': 'pole', 'speed': SPEED, 'step_length': 0.06, 'position_tolerance': TOL, 'start': 0.2,
        'auto_steps': 1, 'frame_prefix': 'robot_7/', 'odometry_length_stddev': 1e-4})
    probe = Probe(context=ros_context)
    odometry = probe.collect(Odometry, 'odometry')
    status = probe.collect(DiagnosticStatus, 'climb/status')
    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(lambda: any(s.message == 'idle' and _values(s)['steps_done'] == '1' for s in status))
        n = len(odometry)
        assert wait_for(lambda: len(odometry) > n + 3)  # a few at rest after the step
    msgs = list(odometry)
    assert {(m.header.frame_id, m.child_frame_id) for m in msgs} == {('robot_7/odom', 'robot_7/base_link')}
    t = np.array([stamp_to_seconds(m.header.stamp) for m in msgs])
    assert np.all(np.diff(t) > 0.0)
    p = np.array([[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z] for m in msgs])
    q = np.array([[m.pose.pose.orientation.x, m.pose.pose.orientation.y, m.pose.pose.orientation.z,
                   m.pose.pose.orientation.w] for m in msgs])

    # where the plan puts ring_a: one 60 mm step up the pole from s = 0.2
    plan = GaitPlanner(nodes[0].geometry, make_structure('pole')).plan(0.06, 1, start=0.2)
    handovers = sum(1 for a, b in zip(plan.phases[:-1], plan.phases[1:])
                    if (a.gripper_a, a.gripper_b) != (b.gripper_a, b.gripper_b))
    assert np.linalg.norm(p[0] - plan.phases[0].world_T_a.position) <= TOL
    assert np.linalg.norm(p[-1] - plan.phases[-1].world_T_a.position) <= handovers * TOL
    assert p[-1][2] - p[0][2] == pytest.approx(0.06, abs=handovers * TOL)

    # the twist (base_link's frame) rotated into odom and integrated: the displacement
    v = np.array([[m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z] for m in msgs])
    R_prev = quat_xyzw_to_matrix(q[:-1])
    moved = np.einsum('nij,nj->ni', R_prev, v[1:]) * np.diff(t)[:, None]
    np.testing.assert_allclose(moved.sum(axis=0), p[-1] - p[0], atol=1e-9)
    speeds = np.linalg.norm(v, axis=1)
    assert 0.5 * SPEED < speeds.max() < 3.0 * SPEED  # ring_a moved at the climb's speed, no jump

    # covariances: symmetric, positive semi-definite; the pose's grew over the step's hand-overs
    pose_cov = [np.array(m.pose.covariance).reshape(6, 6) for m in msgs]
    twist_cov = [np.array(m.twist.covariance).reshape(6, 6) for m in msgs]
    for C in (pose_cov[0], pose_cov[-1], twist_cov[-1]):
        np.testing.assert_allclose(C, C.T, atol=1e-18)
        assert np.linalg.eigvalsh(C).min() >= -1e-15
    assert np.trace(pose_cov[0]) == 0.0 < np.trace(pose_cov[-1])
    # while ring_a grips the base stands: its pose did not move between consecutive samples
    assert Pose(p[-1], q[-1]) == Pose(p[-2], q[-2])
