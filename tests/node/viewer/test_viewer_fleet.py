"""The viewer of a fleet in-process: it lists every robot and, for the controlling operator only,
switches the robot the master drives (the teleop node's robot_namespace), drawing it from then on
with the clutch released."""

from __future__ import annotations

import pytest

from rrps_testing.processes import free_port
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

TOKEN = 'fleet-node-token'
ROBOTS = ['/robot_1', '/robot_2']


def test_the_controller_switches_the_driven_robot_and_the_viewer_follows(ros_context):
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
    from rclpy.parameter import Parameter

    from rrps_interfaces.climb import ClimbState, ClimbStatus
    from rrps_teleop.nodes.teleop_node import TeleopNode
    from rrps_viewer.nodes.viewer_node import ViewerNode
    from rrps_viewer.operator_requests import OperatorRequest

    viewer = ViewerNode(context=ros_context, parameter_overrides=[
        Parameter('port', value=free_port()), Parameter('token', value=TOKEN),
        Parameter('robots', value=ROBOTS), Parameter('robot_topics', value='link'),
        Parameter('workspace_resolution', value=0.0)])
    told: list = []
    viewer.viewer.tell = lambda cid, message, ok: told.append((cid, message, ok))
    teleop = TeleopNode(context=ros_context, parameter_overrides=[
        Parameter('robot_topics', value='link'), Parameter('robot_namespace', value='/robot_1')])
    probe = Probe(context=ros_context)
    climb = {ns: probe.publisher(DiagnosticStatus, f'{ns}/climb/status') for ns in ROBOTS}
    status = DiagnosticStatus(name='climb_node', message='idle', values=[
        KeyValue(key=k, value=v) for k, v in ClimbStatus(state=ClimbState.IDLE).to_values().items()])
    control = viewer.control
    with Spinner(ros_context, [viewer, teleop, probe]):
        assert viewer.robots.robots == ROBOTS and viewer.robots.selected == '/robot_1'
        assert wait_for(lambda: all(p.get_subscription_count() for p in climb.values()), 10.0)
        for _ in range(3):
            for pub in climb.values():
                pub.publish(status)
        assert wait_for(lambda: viewer.robots.heard_count(2.0) == 2, 10.0)
        lines = '\n'.join(viewer.robots.panel_lines())
        assert '**robot_1**' in lines and '**robot_2**' in lines and '▶ **robot_1**' in lines

        # a read-only viewer cannot switch
        control.connect(5)
        viewer.select_robot(5, 'robot_2')
        assert wait_for(lambda: any(c == 5 and not ok for c, _, ok in told), 10.0)
        assert teleop.robot_namespace == '/robot_1'
        # the controller, clutch engaged, can: teleop drives robot_2, the viewer draws it, the
        # clutch is released and the requests go to robot_2
        control.connect(7)
        assert control.authenticate(7, TOKEN).ok and control.take_control(7).ok
        assert control.set_clutch(7, True).ok
        viewer.select_robot(7, 'robot_2')
        assert wait_for(lambda: any(c == 7 and ok and 'drive' in m for c, m, ok in told), 10.0), told
        assert wait_for(lambda: viewer.robots.selected == '/robot_2', 5.0)
        assert teleop.robot_namespace == '/robot_2'
        assert not control.clutch_engaged
        assert viewer.requests._client(OperatorRequest.STEP_UP, None).name.startswith('/robot_2/climb/step')
        viewer.select_robot(7, 'robot_9')
        assert wait_for(lambda: any('unknown robot' in m for _, m, _ in told), 5.0)
    viewer.destroy_node()
    teleop.destroy_node()
