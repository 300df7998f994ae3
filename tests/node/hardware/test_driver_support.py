"""driver_node and teleop_node follow the odometry's supporting ring (``odometry/support``) over
ROS: the simulated gravity turns to the attitude sent for the ring that grips (checked against
the world's gravity turned by the test's own rotation), a malformed message or one for the other
ring changes nothing, and a silent odometry keeps the last known attitude with the status saying
so; teleop's load guards switch ring with ``grippers/state``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TransformStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from rrps_hardware.nodes.driver_node import DriverNode
from rrps_interfaces.driver import DriverStatus, SupportSource
from rrps_interfaces.teleop import TeleopStatus
from rrps_runtime.messages import joint_state_msg, pose_to_msg, transform_to_msg
from rrps_runtime.qos import LATCHED_QOS
from rrps_teleop.nodes.teleop_node import TeleopNode
from rrps_testing.node_helpers import statuses
from rrps_testing.ros_harness import Probe, Spinner, wait_for
from rrps_testing.virtual_work import rotation_x

pytestmark = pytest.mark.ros
G = np.array([0.0, 0.0, -9.81])


def _q_x(angle: float) -> tuple:
    return (math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2))


def _send(probe, pub, ring, q, frame='world'):
    pub.publish(transform_to_msg((0.0, 0.0, 0.5), q, frame_id=frame, child_frame_id=ring,
                                 stamp=probe.get_clock().now().to_msg()))


def _gravity_is(node, ring, R) -> bool:
    s = node.hardware.support
    return s.ring == ring and np.allclose(s.gravity_in_support, R.T @ G, atol=1e-9)


def _last_status(diagnostics) -> tuple[DiagnosticStatus, DriverStatus] | None:
    mine = statuses(diagnostics, 'driver_node')
    return (mine[-1], DriverStatus.from_key_values(mine[-1].values)) if mine else None


def test_the_driver_follows_the_supporting_ring_and_keeps_the_last_attitude(ros_context):
    node = DriverNode(context=ros_context, parameter_overrides=[
        Parameter('robot', value='pole_climber'), Parameter('auto_activate', value=True),
        Parameter('support_timeout', value=0.5)])
    probe = Probe(context=ros_context)
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    pub = probe.create_publisher(TransformStamped, 'odometry/support', LATCHED_QOS)
    gripper = probe.create_client(SetBool, 'grippers/ring_a/set')
    lean = math.radians(30.0)
    with Spinner(ros_context, [node, probe]):
        assert _gravity_is(node, 'ring_a', np.eye(3))                     # the parameters: upright
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        _send(probe, pub, 'ring_a', _q_x(lean))
        assert wait_for(lambda: _gravity_is(node, 'ring_a', rotation_x(lean)))
        # the odometry live (sent at 10 Hz, as the climb node does) until a report (every 0.5 s)
        # shows it: one message ages past support_timeout before a starved process reports it
        def followed() -> bool:
            _send(probe, pub, 'ring_a', _q_x(lean))
            s = _last_status(diagnostics)
            return s is not None and s[1].support_source is SupportSource.ODOMETRY \
                and np.allclose(s[1].world_q_support, _q_x(lean), atol=1e-8)
        assert wait_for(followed, period=0.1)
        # a malformed message and one for the ring that does not grip change nothing
        # (one at a time: the latched topic keeps only the newest)
        for k, bad in enumerate([dict(q=(math.nan, 0.0, 0.0, 1.0)), dict(q=_q_x(0.2), frame='ring_a')]):
            _send(probe, pub, 'ring_a', **bad)
            assert wait_for(lambda n=k + 1: node._support.rejected == n)
        _send(probe, pub, 'ring_b', _q_x(0.4))
        assert wait_for(lambda: (s := _last_status(diagnostics)) is not None and s[1].support_rejected == 2)
        assert _gravity_is(node, 'ring_a', rotation_x(lean))
        # the odometry silent: the last attitude stays, WARN says so
        assert wait_for(lambda: (s := _last_status(diagnostics)) is not None
                        and s[1].support_source is SupportSource.STALE and s[0].level == DiagnosticStatus.WARN
                        and 'keeping the last known attitude of ring_a' in s[0].message)
        assert _gravity_is(node, 'ring_a', rotation_x(lean))
        # ring_a opens (once its open time passed): the driver hands over to ring_b itself, then
        # ring_b's odometry turns it
        future = gripper.call_async(SetBool.Request(data=False))
        assert wait_for(future.done) and future.result().success
        assert wait_for(lambda: node.hardware.support.ring == 'ring_b')
        _send(probe, pub, 'ring_b', _q_x(lean + 0.2))
        assert wait_for(lambda: _gravity_is(node, 'ring_b', rotation_x(lean + 0.2)))


def test_teleop_load_guards_switch_ring_with_the_grippers_over_ros(ros_context):
    node = TeleopNode(context=ros_context, parameter_overrides=[Parameter('robot', value='pole_climber')])
    probe = Probe(context=ros_context)
    teleop = probe.collect(DiagnosticStatus, 'teleop/status')
    pub = probe.create_publisher(TransformStamped, 'odometry/support', LATCHED_QOS)
    grippers = probe.publisher(JointState, 'grippers/state')
    pose = probe.publisher(PoseStamped, 'pose')
    lean = math.radians(30.0)

    def said(ring, source):
        return any((s := TeleopStatus.from_key_values(m.values)).support_ring == ring and s.support_source is source
                   for m in list(teleop)[-5:])

    def state(a: bool, b: bool):
        grippers.publish(joint_state_msg(probe.get_clock().now().to_msg(), [float(a), float(b)],
                                         names=['ring_a', 'ring_b']))

    loads = node.mapping.loads
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: said('ring_a', SupportSource.PARAMETERS))
        assert wait_for(lambda: pub.get_subscription_count() == 1 and grippers.get_subscription_count() == 1)
        _send(probe, pub, 'ring_a', _q_x(lean))
        assert wait_for(lambda: np.allclose(loads.support.gravity_in_support, rotation_x(lean).T @ G, atol=1e-9))
        assert wait_for(lambda: said('ring_a', SupportSource.ODOMETRY))
        g = node.geometry                       # the slave at home: a_R_b the identity
        pose.publish(pose_to_msg(g.home_position, g.home_quaternion_xyzw, frame_id='ring_a',
                                 stamp=probe.get_clock().now().to_msg()))
        assert wait_for(lambda: (state(False, True), loads.support.ring == 'ring_b')[1])
        np.testing.assert_allclose(loads.support.gravity_in_support, rotation_x(lean).T @ G, atol=1e-9)
        assert wait_for(lambda: said('ring_b', SupportSource.HANDED_OVER))
        _send(probe, pub, 'ring_b', _q_x(lean + 0.1))
        assert wait_for(lambda: np.allclose(loads.support.gravity_in_support, rotation_x(lean + 0.1).T @ G,
                                            atol=1e-9))
        assert wait_for(lambda: said('ring_b', SupportSource.ODOMETRY))

