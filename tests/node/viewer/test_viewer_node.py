"""viewer_node over ROS without a browser: deadman stream, gizmo -> master, requests, world picture."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_testing.processes import free_port
from rrps_testing.ros_harness import Probe, Spinner, header_time, stamped_between, wait_for

pytestmark = pytest.mark.ros

TOKEN = 'node-test-token'


@pytest.fixture
def viewer(ros_context):
    from rclpy.parameter import Parameter

    from rrps_viewer.nodes.viewer_node import ViewerNode
    node = ViewerNode(context=ros_context, parameter_overrides=[
        Parameter('port', value=free_port()), Parameter('token', value=TOKEN),
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


#: A read-only viewer client whose requests count viewer_node's timer runs (see _ticks).
MARKER = 9


def _ticks(viewer, n: int) -> None:
    """Wait for ``n`` more runs of viewer_node's timer (its 20 Hz tick, which publishes the
    deadman and the gizmo and then executes the browsers' requests): each run answers the one
    request of the read-only MARKER client queued before it. A window of n ticks is viewer_node's
    own time, whatever the load of the machine."""
    for _ in range(n):
        k = len(viewer.told)
        viewer.step(MARKER, 'up')
        assert wait_for(lambda: any(cid == MARKER for cid, _, _ in viewer.told[k:]))


def test_deadman_streams_while_held_and_stops_when_the_operator_disconnects(ros_context, viewer):
    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import Bool

    from rrps_description.pose import Pose
    from rrps_runtime.qos import COMMAND_QOS
    probe = Probe(context=ros_context)
    enables = probe.collect(Bool, 'teleop/enable', qos=COMMAND_QOS)
    # While an operator has control and the gizmo is placed, every tick also publishes the gizmo's
    # target stamped when the tick ran, right after the deadman: the ticks' own times.
    ticks = probe.collect(PoseStamped, 'master/target_pose', qos=COMMAND_QOS)
    control = viewer.control
    with Spinner(ros_context, [viewer, probe]):
        control.connect(MARKER)
        cid = _operator(control)
        viewer.master_target(cid, Pose([0.5, -1.0, 0.3]))
        control.set_clutch(cid, True)
        t_held = probe.now()
        control.set_dragging(cid, True)  # holding the gizmo holds the deadman
        assert wait_for(lambda: sum(m.data for m in enables) >= 20)  # 1 s at 20 Hz
        t_lost = probe.now()
        control.disconnect(cid)
        # The tick running now, the first one after the disconnect (it publishes false) and one
        # more, so that the probe (same executor, later events) has received what they published.
        _ticks(viewer, 3)
        stopped = list(enables)
        _ticks(viewer, 20)  # 1 s of viewer_node's own ticking
        final = list(enables)
        held_ticks = np.array([header_time(m) for m in stamped_between(ticks, t_held, t_lost)])
    trues = [m.data for m in final].count(True)
    # Held: one true per tick (give or take the ticks running at the two switches) ...
    assert len(held_ticks) >= 15 and abs(trues - len(held_ticks)) <= 2, (trues, len(held_ticks))
    # ... and the ticks, by their own stamps, at enable_rate (20 Hz), well above the 10 Hz teleop
    # needs: the median interval (a stall of this loaded process delays single ticks; the
    # deadman's timeout covers those, tested in the teleop tests).
    assert np.median(np.diff(held_ticks)) < 0.075, np.diff(held_ticks)
    # Disconnected: the ticks right after it sent false, never a true after a false, a few
    # explicit falses and then silence (stale = hold) for the rest of the 20 ticks.
    values = [m.data for m in final]
    first_false = values.index(False)
    assert first_false < len(stopped)
    assert not any(values[first_false:])
    assert 1 <= len(values) - first_false <= 6, values[first_false:]


def test_gizmo_drives_the_master_in_its_own_frame_only_while_in_control(ros_context, viewer):
    from geometry_msgs.msg import PoseStamped

    from rrps_description.pose import Pose
    from rrps_description.rotations import rotation_vector_to_quat_xyzw
    from rrps_runtime.messages import pose_from_msg
    from rrps_runtime.qos import COMMAND_QOS
    probe = Probe(context=ros_context)
    targets = probe.collect(PoseStamped, 'master/target_pose', qos=COMMAND_QOS)
    control = viewer.control
    q = rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, 0.2]))
    with Spinner(ros_context, [viewer, probe]):
        control.connect(MARKER)
        viewer.master_target(3, Pose([0.51, -0.98, 0.31], q))   # nobody has control yet
        _ticks(viewer, 6)  # 0.3 s of viewer_node's ticks (the probe has what the first 5 sent)
        assert not targets
        cid = _operator(control)
        assert wait_for(lambda: len(targets) >= 3)
        control.release(cid)
        _ticks(viewer, 3)  # the tick running at the release, one after it, one to deliver it
        n = len(targets)
        _ticks(viewer, 6)
        assert len(targets) == n
    msg = targets[-1]
    assert msg.header.frame_id == 'master_ring_a'
    position, quaternion = pose_from_msg(msg)
    assert np.allclose(position, [0.01, 0.02, 0.11])    # world minus the console origin
    assert np.allclose(Pose(position, quaternion).rotation, Pose(np.zeros(3), q).rotation)


def test_requests_run_only_for_the_controller_and_answers_reach_the_operator(ros_context, viewer):
    from std_srvs.srv import SetBool

    from rrps_teleop.nodes.teleop_node import TeleopNode
    from rrps_viewer.operator_requests import OperatorRequest
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
        assert wait_for(lambda: viewer.told)
        assert viewer.told[-1] == (9, 'read-only: you do not have control', False)
        cid = _operator(control)
        viewer.set_gripper(cid, 'ring_a', False)
        assert wait_for(lambda: len(viewer.told) >= 2)
        assert viewer.told[-1] == (cid, 'open ring_a: refused: the other ring is open', False)
        viewer.step(cid, 'down')                                # no climb node here
        assert wait_for(lambda: len(viewer.told) >= 3)
        assert viewer.told[-1][1].startswith('climb step down: climb/step') and 'not available' in viewer.told[-1][1]
        assert wait_for(lambda: viewer.requests.ready(OperatorRequest.MAPPING))
        viewer.set_mapping(cid, 'joint', 'absolute', 2.5)
        assert wait_for(lambda: len(viewer.told) >= 4)
        assert viewer.told[-1][2], viewer.told[-1]
        viewer.set_mapping(cid, 'cartesian', 'sideways', 2.5)  # the teleop node refuses it
        assert wait_for(lambda: len(viewer.told) >= 5)
        assert not viewer.told[-1][2] and 'rotation_mode' in viewer.told[-1][1]
    values = {p: teleop.get_parameter(p).value for p in ('mode', 'rotation_mode', 'translation_scale')}
    assert values == {'mode': 'joint', 'rotation_mode': 'absolute', 'translation_scale': 2.5}


def test_the_picture_places_the_robot_by_its_gripping_ring(ros_context, viewer):
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState

    from rrps_description.pose import Pose
    from rrps_runtime.messages import pose_to_msg
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
        assert wait_for(lambda: viewer.frame().ghost_world_T_b is not None)
        frame = viewer.frame()
        assert np.allclose(frame.slave.world_T_a.position, world_a.position)
        assert np.allclose(frame.slave.world_T_b.position, world_a.position + a_T_b.position)
        assert np.allclose(frame.ghost_world_T_b.position, world_a.position + g.home_position)
        assert frame.grippers == {'ring_a': 1.0, 'ring_b': 0.0}
        send(0.0, 1.0)                                            # ring_b grips now
        assert wait_for(lambda: viewer.frame().grippers['ring_b'] == 1.0)
        frame = viewer.frame()
        assert np.allclose(frame.slave.world_T_b.position, world_b.position)
        assert np.allclose(frame.slave.world_T_a.position, world_b.position - a_T_b.position)
        assert wait_for(lambda: 'Conditioning' in viewer.frame().panel)  # 4 Hz text
        assert 'Margins' in viewer.frame().panel
        assert len(frame.trails['ring_a']) == 1 and len(frame.trails['ring_b']) == 1


def test_the_payload_slider_shrinks_the_drawn_workspace_to_the_load_feasible_one(ros_context, viewer):
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState

    from rrps_description.rotations import rotation_vector_to_quat_xyzw
    from rrps_runtime.messages import pose_to_msg
    g = viewer.geometry
    probe = Probe(context=ros_context)
    pose_pub, odom_pub = probe.publisher(PoseStamped, 'pose'), probe.publisher(PoseStamped, 'odometry/ring_a')
    grippers_pub = probe.publisher(JointState, 'grippers/state')
    on_wall = rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0]))   # ring_a grips a wall
    stamp = lambda: viewer.get_clock().now().to_msg()  # noqa: E731

    def send() -> None:
        pose_pub.publish(pose_to_msg(g.home_position, g.home_quaternion_xyzw, frame_id='ring_a', stamp=stamp()))
        odom_pub.publish(pose_to_msg([0.0, 0.0, 1.0], on_wall, frame_id='world', stamp=stamp()))
        grippers_pub.publish(JointState(name=['ring_a', 'ring_b'], position=[1.0, 0.0]))

    def snapshot(payload: float):
        found = []

        def drawn() -> bool:
            send()
            ws = viewer.frame().workspace
            found[:] = [ws] if ws is not None and ws.payload == payload else []
            return bool(found)
        assert wait_for(drawn, timeout=60.0, period=0.05)
        return found[0]

    with Spinner(ros_context, [viewer, probe]):
        unloaded = snapshot(0.0)
        assert unloaded.workspace.volume == pytest.approx(unloaded.reachable_volume)
        cid = _operator(viewer.control)
        viewer.set_workspace_payload(cid, 40.0)
        loaded = snapshot(40.0)
        assert 0.0 < loaded.workspace.volume < 0.8 * unloaded.workspace.volume
        assert loaded.reachable_volume == pytest.approx(unloaded.reachable_volume)
        assert wait_for(lambda: 'load-feasible with 40 kg payload' in viewer.frame().panel)
