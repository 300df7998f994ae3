"""master_node over ROS, launch-free: the simulated master robot follows the operator's handle
within its limits and rejects bad targets (the node runs in-process under the namespace /rrps on
a private domain id, ros_context; a Probe is the operator).
"""

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from rrps_kinematics import check_pose, inverse_kinematics
from rrps_runtime.messages import lengths_from_joint_state, pose_from_msg, pose_to_msg
from rrps_teleop.nodes.master_node import MasterNode
from rrps_testing.ros_harness import Probe, Spinner, wait_for
from rrps_testing.teleop_rig import MASTER, NS, params

pytestmark = pytest.mark.ros


def test_master_node_follows_the_handle_within_its_limits_and_rejects_bad_targets(ros_context):
    from diagnostic_msgs.msg import DiagnosticArray
    master = MasterNode(context=ros_context, namespace=NS, parameter_overrides=params(rate=100.0))
    probe = Probe(context=ros_context, namespace=NS)
    states = probe.collect(JointState, 'master/actuators/state')
    poses = probe.collect(PoseStamped, 'master/pose')
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    handle = probe.publisher(PoseStamped, 'master/target_pose', command=True)
    said = lambda text: any(text in s.message for d in diagnostics for s in d.status)  # noqa: E731

    def send(position, quaternion=(0.0, 0.0, 0.0, 1.0), frame='master_ring_a'):
        msg = pose_to_msg(position, quaternion, frame_id=frame, stamp=probe.get_clock().now().to_msg())
        handle.publish(msg)

    goal = MASTER.home_position + [0.003, 0.0, 0.002]
    with Spinner(ros_context, [master, probe]):
        assert wait_for(lambda: poses and handle.get_subscription_count())
        np.testing.assert_allclose(lengths_from_joint_state(states[-1]), MASTER.home_lengths, atol=1e-12)
        assert wait_for(lambda: (send(goal), np.allclose(pose_from_msg(poses[-1])[0], goal, atol=1e-9))[1])
        # Encoders and FK agree: master/pose is the FK of master/actuators/state.
        np.testing.assert_allclose(lengths_from_joint_state(states[-1]),
                                   inverse_kinematics(MASTER, goal, [0, 0, 0, 1]).lengths, atol=1e-9)
        for args, text in ((([0.0, 0.0, 0.2], (0, 0, 0, 1), 'world'), 'frame_id'),
                           (([0.0, np.nan, 0.1],), 'NaN'),
                           (([0.0, 0.0, 0.1], (0, 0, 0, 3)), 'quaternion norm 3 is not 1')):
            assert wait_for(lambda: (send(*args), said(text))[1]), text
        np.testing.assert_allclose(pose_from_msg(poses[-1])[0], goal, atol=1e-9)
        # Far beyond the stroke: the handle stops on the master's own limits.
        assert wait_for(lambda: (send(MASTER.home_position + [0.0, 0.0, 0.2]), said('stopped at the limits'))[1])
        assert check_pose(MASTER, *pose_from_msg(poses[-1]))[0]
        assert master.set_parameters([Parameter('trajectory', value='square')])[0].successful is False
        assert master.set_parameters([Parameter('trajectory', value='circle')])[0].successful
