"""markers_node over ROS: the robot as a MarkerArray in ring_a, and in world once odometry
places it; legs coloured as the viewer colours them; grippers and the target ghost."""

from __future__ import annotations

import os
import secrets
import math

import numpy as np
import pytest

from ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

# A namespace of this run only: other ROS processes on the machine may share the domain id.
NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'


def test_markers_of_the_robot_in_ring_a_and_world(ros_context):
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from visualization_msgs.msg import Marker, MarkerArray

    from rrps_kinematics.geometry import load_robot
    from rrps_kinematics.nodes.common import joint_state_msg, pose_to_msg
    from rrps_kinematics.pose import Pose
    from rrps_teleop.nodes.markers_node import MarkersNode
    from rrps_teleop.viewer import robot_figure

    node = MarkersNode(context=ros_context, namespace=NS,
                       parameter_overrides=[Parameter('rate', value=20.0)])
    probe = Probe(context=ros_context, namespace=NS)
    arrays = probe.collect(MarkerArray, 'robot/markers')
    a_T_b = Pose([0.005, 0.0, 0.43], [0.0, 0.0, math.sin(0.05), math.cos(0.05)])
    stamp = probe.get_clock().now().to_msg
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: probe.count_subscribers(f'{NS}/pose') > 0, timeout=10.0)
        probe.publisher(PoseStamped, 'pose').publish(
            pose_to_msg(a_T_b.position, a_T_b.quaternion_xyzw, frame_id='ring_a', stamp=stamp()))
        assert wait_for(lambda: arrays, timeout=10.0)
        first = arrays[-1]
        probe.publisher(JointState, 'grippers/state').publish(
            joint_state_msg(stamp(), [1.0, 0.0], names=['ring_a', 'ring_b']))
        probe.publisher(PoseStamped, 'odometry/ring_a').publish(
            pose_to_msg([0.0, 0.0, 1.0], [0, 0, 0, 1], frame_id='world', stamp=stamp()))
        probe.publisher(PoseStamped, 'target_pose', command=True).publish(
            pose_to_msg([0.0, 0.0, 0.44], [0, 0, 0, 1], frame_id='ring_a', stamp=stamp()))
        n = len(arrays)
        assert wait_for(lambda: len(arrays) > n + 2 and any(
            m.ns == 'ghost' for m in arrays[-1].markers), timeout=10.0)
        last = arrays[-1]
    assert {m.header.frame_id for m in first.markers} <= {'ring_a', 'world'}
    by_key = {(m.ns, m.id): m for m in last.markers}
    legs = by_key[('legs', 0)]
    assert legs.type == Marker.LINE_LIST and legs.header.frame_id == 'ring_a'
    figure = robot_figure(load_robot('pole_climber'), a_T_b=a_T_b, world_T_a=Pose())
    points = np.array([[p.x, p.y, p.z] for p in legs.points])
    np.testing.assert_allclose(points, figure.leg_points.reshape(-1, 3), atol=1e-9)
    colours = np.array([[c.r, c.g, c.b] for c in legs.colors])[::2] * 255.0
    np.testing.assert_allclose(colours, figure.leg_colours, atol=1e-3)
    closed, opened = by_key[('grippers', 0)].color, by_key[('grippers', 1)].color
    assert (closed.r, closed.g, closed.b) != (opened.r, opened.g, opened.b)
    world_legs = by_key[('world/legs', 0)]
    assert world_legs.header.frame_id == 'world'
    assert world_legs.points[0].z == pytest.approx(points[0][2] + 1.0)
    assert by_key[('ghost', 0)].header.frame_id == 'ring_a'
    assert any(m.ns == 'structure' and m.header.frame_id == 'world'
               for a in arrays for m in a.markers)
