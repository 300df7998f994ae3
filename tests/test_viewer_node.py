"""viewer_node over ROS without a browser: deadman stream, gizmo -> master, requests, world picture."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest

from ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

TOKEN = 'node-test-token'


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


@pytest.fixture
def viewer(ros_context):
    from rclpy.parameter import Parameter

    from rrps_teleop.nodes.viewer_node import ViewerNode
    node = ViewerNode(context=ros_context, parameter_overrides=[
        Parameter('port', value=_free_port()), Parameter('token', value=TOKEN),
        Parameter('master_origin', value=[0.5, -1.0, 0.2])])
    told: list[tuple[int, str, bool]] = []
    node.viewer.tell = lambda cid, message, ok: told.append((cid, message, ok))
    node.told = told
    return node


def _operator(control, client_id: int = 7) -> int:
    control.connect(client_id)
    assert control.authenticate(client_id, TOKEN).ok
    assert control.take_control(client_id).ok
    return client_id


def test_deadman_streams_while_held_and_stops_when_the_operator_disconnects(ros_context, viewer):
    from std_msgs.msg import Bool

    from rrps_kinematics.nodes.common import COMMAND_QOS
    probe = Probe(context=ros_context)
    enables = probe.collect(Bool, 'teleop/enable', qos=COMMAND_QOS, stamped=True)
    control = viewer.control
    with Spinner(ros_context, [viewer, probe]):
        cid = _operator(control)
        control.set_clutch(cid, True)
        control.set_dragging(cid, True)  # holding the gizmo holds the deadman
        time.sleep(1.0)
        control.disconnect(cid)
        t_lost = time.monotonic()
        time.sleep(0.8)
    true_times = np.array([t for t, m in enables if m.data])
    assert len(true_times) >= 15, len(true_times)       # 20 Hz for 1 s
    assert np.max(np.diff(true_times)) < 0.1            # never slower than 10 Hz
    assert true_times[-1] < t_lost + 0.06
    after = [m.data for t, m in enables if t > t_lost + 0.06]
    assert after and not any(after)                      # explicit falses ...
    assert len(after) <= 6                               # ... then silence (stale = hold)


def test_gizmo_drives_the_master_in_its_own_frame_only_while_in_control(ros_context, viewer):
    from geometry_msgs.msg import PoseStamped

    from rrps_kinematics.nodes.common import COMMAND_QOS, pose_from_msg
    from rrps_kinematics.rotations import rotation_vector_to_quat_xyzw
    from rrps_teleop.viewer import Pose
    probe = Probe(context=ros_context)
    targets = probe.collect(PoseStamped, 'master/target_pose', qos=COMMAND_QOS)
    control = viewer.control
    q = rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, 0.2]))
    with Spinner(ros_context, [viewer, probe]):
        viewer.master_target(3, Pose([0.51, -0.98, 0.31], q))   # nobody has control yet
        time.sleep(0.3)
        assert not targets
        cid = _operator(control)
        assert wait_for(lambda: len(targets) >= 3, timeout=2.0)
        control.release(cid)
        time.sleep(0.2)
        n = len(targets)
        time.sleep(0.3)
        assert len(targets) == n
    msg = targets[-1]
    assert msg.header.frame_id == 'master_ring_a'
    position, quaternion = pose_from_msg(msg)
    assert np.allclose(position, [0.01, 0.02, 0.11])    # world minus the console origin
    assert np.allclose(Pose(position, quaternion).rotation, Pose(np.zeros(3), q).rotation)


def test_requests_run_only_for_the_controller_and_answers_reach_the_operator(ros_context, viewer):
    from std_srvs.srv import SetBool

    from rrps_teleop.nodes.teleop_node import TeleopNode
    from rrps_teleop.nodes.viewer_requests import OperatorRequest
    probe = Probe(context=ros_context)

    def refuse(request, response):
        response.success = False
        response.message = 'refused: the other ring is open'
        return response

    probe.create_service(SetBool, 'grippers/ring_a/set', refuse)
    teleop = TeleopNode(context=ros_context)
    control = viewer.control
    with Spinner(ros_context, [viewer, probe, teleop]):
        control.connect(9)
        viewer.step(9, 'up')                                    # a read-only viewer
        assert wait_for(lambda: viewer.told, timeout=2.0)
        assert viewer.told[-1] == (9, 'read-only: you do not have control', False)
        cid = _operator(control)
        viewer.set_gripper(cid, 'ring_a', False)
        assert wait_for(lambda: len(viewer.told) >= 2, timeout=3.0)
        assert viewer.told[-1] == (cid, 'open ring_a: refused: the other ring is open', False)
        viewer.step(cid, 'down')                                # no climb node here
        assert wait_for(lambda: len(viewer.told) >= 3, timeout=3.0)
        assert 'climb/step_down is not available' in viewer.told[-1][1]
        assert wait_for(lambda: viewer.requests.ready(OperatorRequest.MAPPING), 5.0)
        viewer.set_mapping(cid, 'joint', 'absolute', 2.5)
        assert wait_for(lambda: len(viewer.told) >= 4, timeout=3.0)
        assert viewer.told[-1][2], viewer.told[-1]
        viewer.set_mapping(cid, 'cartesian', 'sideways', 2.5)  # the teleop node refuses it
        assert wait_for(lambda: len(viewer.told) >= 5, timeout=3.0)
        assert not viewer.told[-1][2] and 'rotation_mode' in viewer.told[-1][1]
    values = {p: teleop.get_parameter(p).value for p in ('mode', 'rotation_mode', 'translation_scale')}
    assert values == {'mode': 'joint', 'rotation_mode': 'absolute', 'translation_scale': 2.5}


def test_the_picture_places_the_robot_by_its_gripping_ring(ros_context, viewer):
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState

    from rrps_kinematics.nodes.common import pose_to_msg
    from rrps_teleop.viewer import Pose
    g = viewer.geometry
    probe = Probe(context=ros_context)
    publish = {t: probe.publisher(PoseStamped, t) for t in ('pose', 'odometry/ring_a',
                                                           'odometry/ring_b')}
    target_pub = probe.publisher(PoseStamped, 'target_pose', command=True)
    grippers_pub = probe.publisher(JointState, 'grippers/state')
    a_T_b = Pose(g.home_position + [0.01, 0.0, 0.02], [0.0, 0.0, 0.0, 1.0])
    world_a = Pose([0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0])
    world_b = Pose([0.0, 0.0, 2.0], [0.0, 0.0, 0.0, 1.0])
    stamp = lambda: viewer.get_clock().now().to_msg()  # noqa: E731

    def send(closed_a: float, closed_b: float) -> None:
        publish['pose'].publish(pose_to_msg(a_T_b.position, a_T_b.quaternion_xyzw,
                                            frame_id='ring_a', stamp=stamp()))
        target_pub.publish(pose_to_msg(g.home_position, [0, 0, 0, 1], frame_id='ring_a',
                                       stamp=stamp()))
        for topic, pose in (('odometry/ring_a', world_a), ('odometry/ring_b', world_b)):
            publish[topic].publish(pose_to_msg(pose.position, pose.quaternion_xyzw,
                                               frame_id='world', stamp=stamp()))
        grippers_pub.publish(JointState(name=['ring_a', 'ring_b'], position=[closed_a, closed_b]))

    with Spinner(ros_context, [viewer, probe]):
        assert viewer.frame().slave is None                      # nothing to draw yet
        send(1.0, 0.0)
        assert wait_for(lambda: viewer.frame().ghost_world_T_b is not None, timeout=3.0)
        frame = viewer.frame()
        assert np.allclose(frame.slave.world_T_a.position, world_a.position)
        assert np.allclose(frame.slave.world_T_b.position, world_a.position + a_T_b.position)
        assert np.allclose(frame.ghost_world_T_b.position, world_a.position + g.home_position)
        assert frame.grippers == {'ring_a': 1.0, 'ring_b': 0.0}
        send(0.0, 1.0)                                            # ring_b grips now
        assert wait_for(lambda: viewer.frame().grippers['ring_b'] == 1.0, timeout=3.0)
        frame = viewer.frame()
        assert np.allclose(frame.slave.world_T_b.position, world_b.position)
        assert np.allclose(frame.slave.world_T_a.position, world_b.position - a_T_b.position)
        assert wait_for(lambda: 'Conditioning' in viewer.frame().panel, timeout=2.0)  # 4 Hz text
        assert 'Margins' in viewer.frame().panel
        assert len(frame.trails['ring_a']) == 1 and len(frame.trails['ring_b']) == 1
