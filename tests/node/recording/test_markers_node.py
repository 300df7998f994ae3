"""markers_node over ROS: the robot as a MarkerArray in ring_a, and in world once odometry
places it; legs coloured as the viewer colours them; grippers and the target ghost. Live /tf:
the transforms of robot_transforms (as the recorder writes them, the URDF's moving joints), the
QoS of tf2_ros' TransformBroadcaster, the official Jazzy type hash; /tf_static latched with the
URDF's fixed joints; without tf2_msgs the markers only."""

from __future__ import annotations

import importlib.util
import math
import os
import secrets
import sys

import numpy as np
import pytest

from rrps_testing.ci import require
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

# A namespace of this run only: other ROS processes on the machine may share the domain id.
NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'


def test_markers_of_the_robot_in_ring_a_and_odom(ros_context):
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from visualization_msgs.msg import Marker, MarkerArray

    from rrps_description.geometry import load_robot
    from rrps_description.pose import Pose
    from rrps_kinematics.scene import robot_figure
    from rrps_recording.nodes.markers_node import MarkersNode
    from rrps_runtime.messages import joint_state_msg, pose_to_msg

    node = MarkersNode(context=ros_context, namespace=NS,
                       parameter_overrides=[Parameter('rate', value=20.0)])
    probe = Probe(context=ros_context, namespace=NS)
    arrays = probe.collect(MarkerArray, 'robot/markers')
    a_T_b = Pose([0.005, 0.0, 0.43], [0.0, 0.0, math.sin(0.05), math.cos(0.05)])
    stamp = probe.get_clock().now().to_msg
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: probe.count_subscribers(f'{NS}/pose') > 0)
        probe.publisher(PoseStamped, 'pose').publish(
            pose_to_msg(a_T_b.position, a_T_b.quaternion_xyzw, frame_id='ring_a', stamp=stamp()))
        assert wait_for(lambda: arrays)
        first = arrays[-1]
        probe.publisher(JointState, 'grippers/state').publish(
            joint_state_msg(stamp(), [1.0, 0.0], names=['ring_a', 'ring_b']))
        probe.publisher(PoseStamped, 'odometry/ring_a').publish(
            pose_to_msg([0.0, 0.0, 1.0], [0, 0, 0, 1], frame_id='odom', stamp=stamp()))
        probe.publisher(PoseStamped, 'target_pose', command=True).publish(
            pose_to_msg([0.0, 0.0, 0.44], [0, 0, 0, 1], frame_id='ring_a', stamp=stamp()))
        n = len(arrays)
        assert wait_for(lambda: len(arrays) > n + 2 and any(
            m.ns == 'ghost' for m in arrays[-1].markers))
        last = arrays[-1]
    assert {m.header.frame_id for m in first.markers} <= {'ring_a', 'odom'}
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
    world_legs = by_key[('odom/legs', 0)]
    assert world_legs.header.frame_id == 'odom'
    assert world_legs.points[0].z == pytest.approx(points[0][2] + 1.0)
    assert by_key[('ghost', 0)].header.frame_id == 'ring_a'
    assert any(m.ns == 'structure' and m.header.frame_id == 'odom'
               for a in arrays for m in a.markers)


#: The RIHS01 type hash of tf2_msgs/msg/TFMessage on ROS 2 Jazzy, as `ros2 topic info -v /tf`
#: shows it on Jazzy installs from the ROS packages (the upstream tf2_msgs): the one built by
#: tools/build_interfaces.sh must be the same for real tf2 consumers to accept our /tf.
JAZZY_TF_MESSAGE_HASH = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'


def _require_tf2_msgs() -> None:
    require(importlib.util.find_spec('tf2_msgs') is not None,
            'tf2_msgs is not installed (./rrps builds it when cmake and a C compiler are there)')


def _by_frames(msg) -> dict:
    return {(t.header.frame_id, t.child_frame_id): t for t in msg.transforms}


def _assert_transforms(msg, expected) -> None:
    got = _by_frames(msg)
    assert set(got) == {(parent, child) for parent, child, _ in expected}
    for parent, child, pose in expected:
        t = got[(parent, child)].transform
        np.testing.assert_allclose([t.translation.x, t.translation.y, t.translation.z],
                                   pose.position, atol=1e-12)
        np.testing.assert_allclose([t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w],
                                   pose.quaternion_xyzw, atol=1e-12)


def test_live_tf_agrees_with_robot_transforms(ros_context):
    _require_tf2_msgs()
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    from rrps_description.geometry import load_robot
    from rrps_description.pose import Pose
    from rrps_recording.markers import robot_transforms
    from rrps_recording.nodes.markers_node import MarkersNode
    from rrps_runtime.messages import joint_state_msg, pose_to_msg

    geometry = load_robot('pole_climber')
    node = MarkersNode(context=ros_context, namespace=NS,
                       parameter_overrides=[Parameter('tf_rate', value=50.0)])
    probe = Probe(context=ros_context, namespace=NS)
    tf = probe.collect(TFMessage, '/tf')
    a_T_b = Pose([0.004, -0.003, 0.42], [0.0, 0.0, math.sin(0.04), math.cos(0.04)])
    world_T_a = Pose([0.1, 0.2, 1.0], [0.0, 0.0, math.sin(0.3), math.cos(0.3)])
    world_T_b = Pose([0.1, 0.2, 1.6], [0.0, 0.0, 0.0, 1.0])
    stamp = probe.get_clock().now().to_msg
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: probe.count_subscribers(f'{NS}/pose') > 0
                        and probe.get_publishers_info_by_topic('/tf'))
        [info] = probe.get_publishers_info_by_topic('/tf')
        probe.publisher(PoseStamped, 'pose').publish(
            pose_to_msg(a_T_b.position, a_T_b.quaternion_xyzw, frame_id='ring_a', stamp=stamp()))
        # no odometry yet: the URDF's moving joints, no world
        assert wait_for(lambda: tf)
        _assert_transforms(tf[-1], robot_transforms(geometry, a_T_b, fixed=False))
        probe.publisher(PoseStamped, 'odometry/ring_a').publish(
            pose_to_msg(world_T_a.position, world_T_a.quaternion_xyzw, frame_id='odom',
                        stamp=stamp()))
        assert wait_for(lambda: ('odom', 'base_link') in _by_frames(tf[-1]))
        _assert_transforms(tf[-1], robot_transforms(geometry, a_T_b, world_T_a, fixed=False))
        # ring_a open, ring_b grips: odom -> base_link through ring_b's odometry
        probe.publisher(PoseStamped, 'odometry/ring_b').publish(
            pose_to_msg(world_T_b.position, world_T_b.quaternion_xyzw, frame_id='odom',
                        stamp=stamp()))
        probe.publisher(JointState, 'grippers/state').publish(
            joint_state_msg(stamp(), [0.0, 1.0], names=['ring_a', 'ring_b']))
        expected = robot_transforms(geometry, a_T_b, world_T_b.compose(a_T_b.inverse()), fixed=False)
        assert wait_for(lambda: _by_frames(tf[-1])[('odom', 'base_link')].transform.translation.z
                        == pytest.approx(expected[0][2].position[2], abs=1e-12))
        _assert_transforms(tf[-1], expected)
    assert info.node_name == 'markers_node' and info.topic_type == 'tf2_msgs/msg/TFMessage'
    # what tf2_ros' TransformBroadcaster offers (the graph does not carry history and depth)
    offered = info.qos_profile
    assert (offered.reliability, offered.durability) == (ReliabilityPolicy.RELIABLE,
                                                         DurabilityPolicy.VOLATILE)
    assert (node._tf_pub.qos_profile.history, node._tf_pub.qos_profile.depth) == (
        HistoryPolicy.KEEP_LAST, 100)
    now = probe.get_clock().now().nanoseconds * 1e-9
    last = tf[-1].transforms[0].header.stamp
    assert 0.0 <= now - (last.sec + 1e-9 * last.nanosec) < 30.0
    assert node.tf_published >= 3


def test_tf_static_is_latched_and_tf_turns_the_grippers_of_the_extra_ring_dof(ros_context):
    """/tf_static: the URDF's fixed joints, for a subscriber that joins later (as tf2_ros'
    StaticTransformBroadcaster); /tf: a ring's extra DOF once actuators/state measures it."""
    _require_tf2_msgs()
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    from rrps_description.geometry import load_robot
    from rrps_description.pose import Pose
    from rrps_recording.markers import fixed_transforms, robot_transforms
    from rrps_recording.nodes.markers_node import MarkersNode
    from rrps_runtime.messages import joint_state_msg, pose_to_msg
    from rrps_runtime.qos import LATCHED_QOS

    geometry = load_robot('frame_climber')
    node = MarkersNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('robot', value='frame_climber'), Parameter('tf_rate', value=50.0)])
    probe = Probe(context=ros_context, namespace=NS)
    static: list = []
    probe.create_subscription(TFMessage, '/tf_static', static.append, LATCHED_QOS)  # joins late
    tf = probe.collect(TFMessage, '/tf')
    a_T_b = Pose(geometry.home_position, geometry.home_quaternion_xyzw)
    stamp = probe.get_clock().now().to_msg
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: static and probe.count_subscribers(f'{NS}/actuators/state') > 0)
        [info] = probe.get_publishers_info_by_topic('/tf_static')
        probe.publisher(PoseStamped, 'pose').publish(
            pose_to_msg(a_T_b.position, a_T_b.quaternion_xyzw, frame_id='ring_a', stamp=stamp()))
        assert wait_for(lambda: tf)
        assert ('ring_a', 'ring_a_gripper') not in _by_frames(tf[-1])  # not measured yet
        probe.publisher(JointState, 'actuators/state').publish(joint_state_msg(
            stamp(), [*geometry.home_lengths, 0.5, -0.25],
            names=[f'leg_{i}' for i in range(1, 7)] + ['ring_a_rotation', 'ring_b_rotation']))
        assert wait_for(lambda: ('ring_a', 'ring_a_gripper') in _by_frames(tf[-1]))
        _assert_transforms(tf[-1], robot_transforms(
            geometry, a_T_b, None, {'ring_a_rotation': 0.5, 'ring_b_rotation': -0.25}, fixed=False))
    assert info.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    _assert_transforms(static[-1], fixed_transforms(geometry))
    assert ('leg_1_tip', 'ring_b') in _by_frames(static[-1])


def test_tf2_msgs_type_hash_is_the_official_jazzy_one(ros_context):
    _require_tf2_msgs()
    from rrps_recording.nodes.markers_node import MarkersNode
    from rrps_recording.topic_graph import type_hash_text

    node = MarkersNode(context=ros_context, namespace=NS)
    probe = Probe(context=ros_context, namespace=NS)
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: probe.get_publishers_info_by_topic('/tf'))
        [info] = probe.get_publishers_info_by_topic('/tf')
    assert type_hash_text(info.topic_type_hash) == JAZZY_TF_MESSAGE_HASH


def test_without_tf2_msgs_or_at_tf_rate_0_only_the_markers(ros_context, monkeypatch):
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from visualization_msgs.msg import MarkerArray

    from rrps_recording.nodes.markers_node import MarkersNode
    from rrps_runtime.messages import pose_to_msg

    off = MarkersNode(context=ros_context, namespace=f'{NS}/off',
                      parameter_overrides=[Parameter('tf_rate', value=0.0)])
    monkeypatch.setitem(sys.modules, 'tf2_msgs.msg', None)  # `from tf2_msgs.msg import` fails
    missing = MarkersNode(context=ros_context, namespace=f'{NS}/missing')
    probe = Probe(context=ros_context, namespace=NS)
    arrays = probe.collect(MarkerArray, 'missing/robot/markers')
    with Spinner(ros_context, [off, missing, probe]):
        assert wait_for(lambda: probe.count_subscribers(f'{NS}/missing/pose') > 0)
        probe.publisher(PoseStamped, 'missing/pose').publish(
            pose_to_msg([0.0, 0.0, 0.43], [0, 0, 0, 1], frame_id='ring_a',
                        stamp=probe.get_clock().now().to_msg()))
        assert wait_for(lambda: arrays)
        assert probe.get_publishers_info_by_topic('/tf') == []
    assert off.tf_published == 0 and missing.tf_published == 0


def test_the_frame_is_drawn_with_its_member_bent_at_the_node(ros_context):
    from rclpy.parameter import Parameter

    from rrps_description.structures import make_structure
    from rrps_recording.nodes.markers_node import MarkersNode

    node = MarkersNode(context=ros_context, namespace=f'{NS}/frame', parameter_overrides=[
        Parameter('structure', value='frame'), Parameter('junction_deg', value=90.0),
        Parameter('out_of_plane', value=True), Parameter('tf_rate', value=0.0)])
    try:
        points = np.array([[p.x, p.y, p.z] for p in node._structure.points])
    finally:
        node.destroy_node()
    top = make_structure('frame', junction_deg=90.0, out_of_plane=True).nodes['top']
    assert np.allclose(top, [0.0, 2.0, 2.0])                 # the member leaves the node along y
    assert np.min(np.linalg.norm(points - top, axis=1)) < 0.1  # and is drawn
