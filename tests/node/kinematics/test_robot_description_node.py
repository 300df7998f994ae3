"""robot_description_node in-process: the URDF latched on robot_description (a late subscriber
gets it), joint_states following a moving pose at a bounded rate, the extra ring DOF from
actuators/state, and bad poses rejected."""

import math
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.nodes.robot_description_node import RobotDescriptionNode
from rrps_kinematics.urdf_joints import joint_values, robot_model, robot_urdf
from rrps_runtime.messages import joint_state_msg, pose_to_msg
from rrps_runtime.qos import LATCHED_QOS
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros


def test_robot_description_is_latched_for_a_late_subscriber(ros_context):
    node = RobotDescriptionNode(context=ros_context, namespace='/t',
                                parameter_overrides=[Parameter('robot', value='frame_climber')])
    probe = Probe(context=ros_context, namespace='/t')
    # subscribed after the node published its one message
    late: list[String] = []
    probe.create_subscription(String, 'robot_description', late.append, LATCHED_QOS)
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: late)
        [info] = probe.get_publishers_info_by_topic('/t/robot_description')
    assert [m.data for m in late] == [robot_urdf(load_robot('frame_climber'))]
    assert (info.qos_profile.reliability, info.qos_profile.durability) == (
        ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL)
    assert node.published == 0  # no pose yet: no joint_states


def test_joint_states_follow_a_moving_pose_at_a_bounded_rate(ros_context):
    g = load_robot('pole_climber')
    node = RobotDescriptionNode(context=ros_context, namespace='/t',
                                parameter_overrides=[Parameter('rate', value=20.0)])
    probe = Probe(context=ros_context, namespace='/t')
    states = probe.collect(JointState, 'joint_states', stamped=True)
    pub = probe.publisher(PoseStamped, 'pose')
    sent = []
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        t0 = probe.now()
        for k in range(150):  # 150 poses over about 1.5 s: far more than 20 Hz
            pose = Pose(g.home_position + [0.02 * math.sin(0.05 * k), 0.0, 0.01 * math.cos(0.05 * k)],
                        rotation_vector_to_quat_xyzw([0.0, 0.0, 0.002 * k]))
            msg = pose_to_msg(pose.position, pose.quaternion_xyzw, frame_id='ring_a',
                              stamp=probe.get_clock().now().to_msg())
            sent.append((msg.header.stamp, pose))
            pub.publish(msg)
            time.sleep(0.01)  # the pose stream's pace
        assert wait_for(lambda: states and states[-1][1].header.stamp == sent[-1][0])
        span = probe.now() - t0
    assert 10 <= len(states) <= 20.0 * span + 3
    by_stamp = {(s.sec, s.nanosec): pose for s, pose in sent}
    names = list(robot_model(g).moving_joints)
    heights = []
    for _, msg in states:
        pose = by_stamp[(msg.header.stamp.sec, msg.header.stamp.nanosec)]  # stamped as the pose
        assert list(msg.name) == names
        expected = joint_values(g, pose)
        np.testing.assert_allclose(msg.position, [expected[n] for n in names], atol=1e-12)
        np.testing.assert_allclose([msg.position[names.index(f'leg_{i}')] for i in range(1, 7)],
                                   inverse_kinematics(g, pose.position, pose.quaternion_xyzw).lengths, atol=1e-12)
        heights.append(pose.position[2])
    assert np.ptp(heights) > 0.01  # it followed the motion


def test_extra_ring_dof_from_actuators_state_and_bad_poses_rejected(ros_context):
    g = load_robot('frame_climber')
    node = RobotDescriptionNode(context=ros_context, namespace='/t',
                                parameter_overrides=[Parameter('robot', value='frame_climber')])
    probe = Probe(context=ros_context, namespace='/t')
    states = probe.collect(JointState, 'joint_states')
    pose_pub = probe.publisher(PoseStamped, 'pose')
    state_pub = probe.publisher(JointState, 'actuators/state')
    stamp = probe.get_clock().now().to_msg
    home = pose_to_msg(g.home_position, g.home_quaternion_xyzw, frame_id='ring_a', stamp=stamp())
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pose_pub.get_subscription_count() == 1 and state_pub.get_subscription_count() == 1)
        pose_pub.publish(home)
        assert wait_for(lambda: states)
        assert 'ring_a_rotation' not in states[-1].name  # not measured yet: left out
        state_pub.publish(joint_state_msg(stamp(), [*g.home_lengths, 0.3, math.nan],
                                          names=['leg_1', 'leg_2', 'leg_3', 'leg_4', 'leg_5', 'leg_6',
                                                 'ring_a_rotation', 'ring_b_rotation']))
        # the next pose's joint states carry the measured angle
        assert wait_for(lambda: pose_pub.publish(home) or 'ring_a_rotation' in states[-1].name)
        last = dict(zip(states[-1].name, states[-1].position))
        assert last['ring_a_rotation'] == 0.3 and 'ring_b_rotation' not in last  # NaN: left out
        # the home poses published while waiting may still be in flight: counted once none came for 0.3 s
        n = -1
        while n != len(states):
            n = len(states)
            time.sleep(0.3)
        bad = pose_to_msg(g.home_position, [0.0, 0.0, 0.0, 2.0], frame_id='ring_a', stamp=stamp())
        other_frame = pose_to_msg(g.home_position, g.home_quaternion_xyzw, frame_id='world', stamp=stamp())
        for msg in (bad, other_frame):
            rejected = node.rejected
            pose_pub.publish(msg)
            assert wait_for(lambda: node.rejected == rejected + 1)
    assert len(states) == n
