"""Command timeouts without synchronised clocks: senders whose clock is 2 s ahead or behind.

The IK node and the driver learn each sender's clock (rrps_runtime.freshness.CommandFreshness):
a fresh command stream is acted on, a command delayed by more than the timeout is not.
"""

from __future__ import annotations

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from rrps_description.geometry import load_robot
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_runtime.qos import COMMAND_QOS
from rrps_testing.node_helpers import command, said, target
from rrps_testing.ros_harness import Probe, Spinner, settled, wait_for

pytestmark = pytest.mark.ros

POLE = load_robot('pole_climber')
DEADLINE = 30.0


@pytest.mark.parametrize('offset', [2.0, -2.0])
def test_ik_node_follows_a_sender_with_an_offset_clock_and_refuses_its_late_targets(ros_context, offset):
    node = IkNode(context=ros_context)
    probe = Probe(context=ros_context)
    commands = probe.collect(JointState, 'actuators/command', qos=COMMAND_QOS, stamped=True)
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    targets = probe.publisher(PoseStamped, 'target_pose', command=True)
    p = POLE.home_position + [0.0, 0.0, 0.01]
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: targets.get_subscription_count() == 1, DEADLINE)
        # age = -offset: the sender's clock reads `offset` s more than this host's
        assert wait_for(lambda: (targets.publish(target(probe, p, age=-offset)), commands)[1],
                        DEADLINE, period=0.02), 'a fresh stream from the offset clock was never acted on'
        np.testing.assert_allclose(commands[-1][1].position,
                                   inverse_kinematics(POLE, p, [0, 0, 0, 1]).lengths, atol=1e-12)
        accepted = settled(lambda: node.accepted)  # the stream's queued commands taken
        late = p + [0.0, 0.0, 0.005]
        targets.publish(target(probe, late, age=-offset + 0.3))  # 0.3 s late by the sender's clock
        assert wait_for(lambda: said(diagnostics, 'ik_node', 'stale'), DEADLINE)
        assert node.accepted == accepted
        assert not any(np.allclose(m.position, inverse_kinematics(POLE, late, [0, 0, 0, 1]).lengths)
                       for _, m in commands)
        n = len(commands)
        assert wait_for(lambda: (targets.publish(target(probe, p, age=-offset)), len(commands) > n)[1],
                        DEADLINE, period=0.02)  # the stream goes on


@pytest.mark.parametrize('offset', [2.0, -2.0])
def test_driver_follows_a_sender_with_an_offset_clock_and_refuses_its_late_commands(ros_context, offset):
    node = DriverNode(context=ros_context, parameter_overrides=[Parameter('auto_activate', value=True)])
    probe = Probe(context=ros_context)
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    pub = probe.publisher(JointState, 'actuators/command', command=True)
    goal = POLE.home_lengths + 0.002
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1, DEADLINE)
        assert wait_for(lambda: (pub.publish(command(probe, goal, age=-offset)), node.accepted)[1],
                        DEADLINE, period=0.02)
        # the accepted command becomes the reference at the driver's next cycle
        assert wait_for(lambda: np.allclose(node.reference, goal, rtol=0, atol=1e-12), DEADLINE)
        accepted = settled(lambda: node.accepted)  # the stream's queued commands taken
        pub.publish(command(probe, goal + 0.003, age=-offset + 0.3))
        assert wait_for(lambda: said(diagnostics, 'driver_node', 'stale'), DEADLINE)
        assert node.accepted == accepted
        np.testing.assert_allclose(node.reference, goal)
