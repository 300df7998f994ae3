"""fk_node in-process: actuators/state -> pose, warm-started; bad input, non-convergence and jumps."""

import time

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.nodes.fk_node import FkNode
from rrps_kinematics.tracking import PoseTracker
from rrps_runtime.messages import joint_state_msg
from rrps_testing.node_helpers import pose_error, said, statuses
from rrps_testing.ros_harness import Probe, Spinner, wait_for

POLE = load_robot('pole_climber')

pytestmark = pytest.mark.ros


def test_pose_of_measured_lengths_and_every_failure_keeps_the_last_estimate(ros_context):
    node = FkNode(context=ros_context, namespace='/t')
    probe = Probe(context=ros_context, namespace='/t')
    poses = probe.collect(PoseStamped, 'pose')
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    pub = probe.publisher(JointState, 'actuators/state')
    stamp = probe.get_clock().now().to_msg()
    p = POLE.home_position + [0.012, -0.008, 0.02]
    q = rotation_vector_to_quat_xyzw(np.array([0.04, 0.03, -0.06]))
    lengths = inverse_kinematics(POLE, p, q).lengths
    # lengths of a far pose whose solution from here lies across a singularity (checked offline)
    far_lengths = inverse_kinematics(POLE, [0.1625, -0.0235, 0.3632], [-0.2923, 0.5986, 0.4026, 0.6278]).lengths
    tracker = PoseTracker(POLE)
    tracker.reset(p, q)
    assert 'det(J)' in tracker.update(far_lengths).reason
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        pub.publish(joint_state_msg(stamp, lengths))
        assert wait_for(lambda: poses)
        translation, rotation = pose_error(poses[0], p, q)
        assert translation < 1e-9 and rotation < 1e-9
        assert poses[0].header.frame_id == 'ring_a' and poses[0].header.stamp == stamp
        assert wait_for(lambda: any(s.message == 'tracking actuators/state' and
                                    {'converged', 'iterations', 'residual', 'inverse_condition'}
                                    <= {kv.key for kv in s.values}
                                    for s in statuses(diagnostics, 'fk_node')))
        bad = [
            (joint_state_msg(stamp, [0.4] * 5, names=['leg_1', 'leg_2', 'leg_3', 'leg_4', 'leg_5']), 'missing joints'),
            (joint_state_msg(stamp, [0.4] * 5 + [np.nan]), 'NaN'),
            (JointState(position=[0.4] * 7), 'expected 6 positions'),
            (joint_state_msg(stamp, [0.01, 0.9, 0.01, 0.9, 0.01, 0.9]), 'no convergence'),
            (joint_state_msg(stamp, far_lengths), 'det(J) changed sign'),
        ]
        for msg, text in bad:
            failed = node.failed
            pub.publish(msg)
            assert wait_for(lambda: node.failed > failed and said(diagnostics, 'fk_node', text)), text
            assert len(poses) == 1, text
            translation, _ = pose_error(poses[0], node.position, node.quaternion_xyzw)
            assert translation == 0.0
        pub.publish(joint_state_msg(stamp, inverse_kinematics(POLE, p + [0.0, 0.0, 0.001], q).lengths))
        assert wait_for(lambda: len(poses) == 2)
        assert pose_error(poses[1], p + [0.0, 0.0, 0.001], q)[0] < 1e-9


def test_far_initial_lengths_and_run_time_max_jump(ros_context):
    node = FkNode(context=ros_context, namespace='/t')
    probe = Probe(context=ros_context, namespace='/t')
    poses = probe.collect(PoseStamped, 'pose')
    pub = probe.publisher(JointState, 'actuators/state')
    far = [POLE.home_position + [0.0, 0.0, 0.06], POLE.home_position + [0.0, 0.0, -0.05]]
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        for k, p in enumerate(far):  # 0.06 m from home, then 0.11 m: solved by continuation
            if k == 1:
                assert node.set_parameters([Parameter('max_jump', value=0.2)])[0].successful
                assert node.tracker.max_jump == 0.2  # direct solve
            pub.publish(joint_state_msg(probe.get_clock().now().to_msg(),
                                        inverse_kinematics(POLE, p, [0, 0, 0, 1]).lengths))
            assert wait_for(lambda: len(poses) == k + 1)
            assert pose_error(poses[k], p, [0, 0, 0, 1])[0] < 1e-9


def test_parameter_ranges_are_enforced(ros_context):
    node = FkNode(context=ros_context)
    assert not node.set_parameters([Parameter('max_jump', value=-1.0)])[0].successful
    assert not node.set_parameters([Parameter('robot', value='frame_climber')])[0].successful  # read-only
    assert node.tracker.max_jump == 0.05
    node.destroy_node()


def test_a_robot_at_rest_is_recorded_with_every_stamp_while_tapped(ros_context):
    """At rest fk_node re-stamps and re-publishes its last pose. While a recorder listens, its tap
    keeps the bytes of each pose as it went out: the bundles hold every stamp, in order (a tap
    that kept the message itself would show the last stamp in each bundle)."""
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import UInt8MultiArray

    from rrps_interfaces.recording import RECORDING_TAP
    from rrps_runtime.recording_bundle import decode_bundle
    from rrps_runtime.recording_tap import TAP_QOS
    node = FkNode(context=ros_context, namespace='/t')
    probe = Probe(context=ros_context, namespace='/t')
    bundles = []
    probe.create_subscription(UInt8MultiArray, f'fk_node/{RECORDING_TAP}', bundles.append,
                              TAP_QOS, raw=True)
    poses = probe.collect(PoseStamped, 'pose')
    pub = probe.publisher(JointState, 'actuators/state')
    lengths = inverse_kinematics(POLE, POLE.home_position, [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        assert wait_for(lambda: node._pub.tapped)
        for i in range(40):   # each after the pose before it (a starved process drops a burst from its queue)
            pub.publish(joint_state_msg(Time(sec=100, nanosec=i), lengths))
            assert wait_for(lambda n=i + 1: len(poses) == n)
        time.sleep(0.3)  # the last bundle
    frames = [frame for data in bundles for frame in decode_bundle(data).frames]
    recorded = [deserialize_message(cdr, PoseStamped) for _, _, cdr in frames]
    assert [m.header.stamp.nanosec for m in recorded] == list(range(40))
    assert all(pose_error(m, POLE.home_position, [0, 0, 0, 1])[0] < 1e-9 for m in recorded)
