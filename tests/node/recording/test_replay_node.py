"""replay_node over ROS: a recorded session replayed into a fresh FK and viewer reproduces the
recorded poses; command streams never reach their live names unless allowed; pause, seek and
rate through the node's parameters, reported on replay/status; the recorder's /tf replayed as
tf2_msgs/TFMessage where tf2_msgs is installed, skipped where it is not."""

from __future__ import annotations

import importlib.util
import math
import os
import secrets
import time

import numpy as np
import pytest
from mcap.reader import make_reader

from rrps_testing.ci import require
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

# A namespace of this run only: other ROS processes on the machine may share the domain id.
NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'


def _replay(context, files, **params):
    from rclpy.parameter import Parameter

    from rrps_recording.nodes.replay_node import ReplayNode
    overrides = {'files': [str(f) for f in files], **params}
    return ReplayNode(context=context, namespace=NS, parameter_overrides=[
        Parameter(k, value=v) for k, v in overrides.items()])


def _status_of(statuses):
    from rrps_interfaces.recording import ReplayStatus
    return ReplayStatus.from_key_values(statuses[-1].values) if statuses else None


def _counts(path) -> dict[str, int]:
    with open(path, 'rb') as stream:
        summary = make_reader(stream).get_summary()
    return {c.topic: summary.statistics.channel_message_counts.get(cid, 0)
            for cid, c in summary.channels.items()}


def test_replay_into_a_fresh_fk_and_viewer_reproduces_the_recorded_poses(ros_context, tmp_path):
    import socket

    from geometry_msgs.msg import PoseStamped
    from mcap_ros2.decoder import DecoderFactory
    from rclpy.parameter import Parameter

    from rrps_hardware.nodes.driver_node import DriverNode
    from rrps_kinematics.nodes.fk_node import FkNode
    from rrps_kinematics.nodes.ik_node import IkNode
    from rrps_recording.nodes.recorder_node import RecorderNode
    from rrps_testing.node_helpers import target
    from rrps_viewer.nodes.viewer_node import ViewerNode

    robot = [Parameter('robot', value='pole_climber')]
    # 1. record a session of the real chain: target_pose -> IK -> driver -> FK -> pose
    recorder = RecorderNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('prefix', value='session'),
        Parameter('discovery_period', value=0.1), Parameter('flight_recorder', value=False)])
    stack = [DriverNode(context=ros_context, namespace=NS,
                        parameter_overrides=robot + [Parameter('rate', value=200.0),
                                                             Parameter('auto_activate', value=True)]),
             IkNode(context=ros_context, namespace=NS, parameter_overrides=robot),
             FkNode(context=ros_context, namespace=NS, parameter_overrides=robot)]
    probe = Probe(context=ros_context, name='session_probe', namespace=NS)
    targets = probe.publisher(PoseStamped, 'target_pose', command=True)
    seen = probe.collect(PoseStamped, 'pose')

    def moved_enough() -> bool:  # enough of a session, whatever the machine's load, ending at rest
        z = [p.pose.position.z for p in list(seen)]  # (the driver's jerk-limited setpoints arrive late)
        return len(z) >= 150 and max(z) - min(z) > 0.01 and max(z[-30:]) - min(z[-30:]) < 1e-9

    with Spinner(ros_context, [recorder, *stack, probe]):
        assert wait_for(lambda: {f'{NS}/pose', f'{NS}/actuators/state'}
                        <= set(recorder._raw_subscriptions))
        assert wait_for(lambda: f'{NS}/target_pose' in recorder._raw_subscriptions)
        for i in range(75):  # 1.5 s: ring_b rises 15 mm and turns a little
            angle = 0.002 * i
            msg = target(probe, [0.0, 0.0, 0.42 + 2e-4 * i],
                         [0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)])
            targets.publish(msg)
            time.sleep(0.02)
        # hold the last target (freshly stamped) until the robot got there and rests
        assert wait_for(lambda: moved_enough() or targets.publish(
            target(probe, [0.0, 0.0, 0.42 + 2e-4 * 74], [0.0, 0.0, np.sin(0.074), np.cos(0.074)]))
            or False, timeout=60.0, period=0.02)
        time.sleep(0.3)
    path = tmp_path / 'session' / 'session_0.mcap'
    recorded = {}
    with open(path, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, pose in reader.iter_decoded_messages(topics=[f'{NS}/pose']):
            recorded[(pose.header.stamp.sec, pose.header.stamp.nanosec)] = pose
    assert len(recorded) >= 150
    z = [p.pose.position.z for p in recorded.values()]
    assert max(z) - min(z) > 0.01  # the robot moved during the session

    # 2. replay only the driver's actuators/state into a fresh FK and a viewer
    fk = FkNode(context=ros_context, namespace=NS, parameter_overrides=robot)
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    viewer = ViewerNode(context=ros_context, namespace=NS, parameter_overrides=robot + [
        Parameter('port', value=port), Parameter('token', value='replay-test-token')])
    # at half speed: at full speed a fresh FK sharing this executor with the viewer posed 191 of 429 states
    # in a fresh-clone suite, while the other worker ran the system tests (it keeps the newest 10 when behind)
    replay = _replay(ros_context, [tmp_path / 'session'], topics=[f'{NS}/actuators/state'], rate=0.5)
    probe = Probe(context=ros_context, name='replay_probe', namespace=NS)
    fresh = probe.collect(PoseStamped, 'pose')
    with Spinner(ros_context, [fk, viewer, replay, probe]):
        assert wait_for(lambda: replay.finished)
        time.sleep(0.5)
        frame = viewer.frame()
    assert replay.published == _counts(path)[f'{NS}/actuators/state']
    assert len(fresh) >= 0.5 * replay.published  # FK keeps the newest 10 when it falls behind
    # The stack's nodes send their poses to the recorder in bundles every 0.1 s (recording
    # taps), so the recording of each topic ends with its node's last bundle: the FK poses of
    # the last recorded states may be missing, none before them.
    last_recorded = max(recorded)
    compared = 0
    for pose in fresh:
        stamp = (pose.header.stamp.sec, pose.header.stamp.nanosec)
        if stamp > last_recorded:
            continue
        compared += 1
        original = recorded[stamp]
        for axis in 'xyz':
            assert getattr(pose.pose.position, axis) == pytest.approx(
                getattr(original.pose.position, axis), abs=1e-9)
        for axis in 'xyzw':
            assert getattr(pose.pose.orientation, axis) == pytest.approx(
                getattr(original.pose.orientation, axis), abs=1e-9)
    assert compared >= len(fresh) - 40  # the tail: at most 0.2 s of poses at 200 Hz
    last = recorded[last_recorded]
    assert frame.slave is not None  # no odometry: ring_a at the world origin
    np.testing.assert_allclose(frame.slave.world_T_b.position,
                               [last.pose.position.x, last.pose.position.y, last.pose.position.z],
                               atol=1e-9)


def _synthetic_recording(path, probe):
    """Recorded commands and a state stream, 1 s at 50 Hz, written with the MCAP writer."""
    from geometry_msgs.msg import PoseStamped
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool

    from rrps_recording.storage.mcap_files import TopicInfo, write_recording
    from rrps_recording.storage.qos import QosSpec
    from rrps_runtime.messages import joint_state_msg, pose_to_msg
    best_effort = (QosSpec(depth=1, reliability=2),)
    topics = [TopicInfo(f'{NS}/target_pose', 'geometry_msgs/msg/PoseStamped', best_effort),
              TopicInfo(f'{NS}/actuators/command', 'sensor_msgs/msg/JointState', best_effort),
              TopicInfo(f'{NS}/teleop/enable', 'std_msgs/msg/Bool', best_effort),
              TopicInfo(f'{NS}/actuators/state', 'sensor_msgs/msg/JointState', (QosSpec(),)),
              TopicInfo('/tf', 'tf2_msgs/msg/TFMessage', (QosSpec(),))]
    t0 = time.time_ns()
    messages = []
    stamp = probe.get_clock().now().to_msg()
    for i in range(50):
        t = t0 + i * 20_000_000
        messages.append((f'{NS}/target_pose', t, serialize_message(
            pose_to_msg([0, 0, 0.42], [0, 0, 0, 1], frame_id='ring_a', stamp=stamp))))
        messages.append((f'{NS}/actuators/command', t, serialize_message(
            joint_state_msg(stamp, [0.43] * 6))))
        messages.append((f'{NS}/teleop/enable', t, serialize_message(Bool(data=True))))
        messages.append((f'{NS}/actuators/state', t, serialize_message(
            joint_state_msg(stamp, [0.43 + 1e-4 * i] * 6))))
    write_recording(path, topics, messages)
    return PoseStamped, JointState, Bool


@pytest.mark.parametrize('allow', [False, True])
def test_command_topics_go_under_replay_unless_allowed(ros_context, tmp_path, allow):
    from diagnostic_msgs.msg import DiagnosticStatus

    from rrps_runtime.qos import COMMAND_QOS
    probe = Probe(context=ros_context, namespace=NS)
    PoseStamped, JointState, Bool = _synthetic_recording(tmp_path / 'commands.mcap', probe)
    live = {'target_pose': probe.collect(PoseStamped, 'target_pose', qos=COMMAND_QOS),
            'actuators/command': probe.collect(JointState, 'actuators/command', qos=COMMAND_QOS),
            'teleop/enable': probe.collect(Bool, 'teleop/enable', qos=COMMAND_QOS)}
    moved = {'target_pose': probe.collect(PoseStamped, 'replay/target_pose', qos=COMMAND_QOS),
             'actuators/command': probe.collect(JointState, 'replay/actuators/command',
                                                qos=COMMAND_QOS),
             'teleop/enable': probe.collect(Bool, 'replay/teleop/enable', qos=COMMAND_QOS)}
    states = probe.collect(JointState, 'actuators/state')
    statuses = probe.collect(DiagnosticStatus, 'replay/status')
    replay = _replay(ros_context, [tmp_path / 'commands.mcap'], paused=True,
                     allow_commands=allow)
    with Spinner(ros_context, [replay, probe]):
        assert wait_for(lambda: all(probe.count_publishers(f'{NS}/{"" if allow else "replay/"}{t}')
                                    for t in live), timeout=10.0)
        assert wait_for(lambda: len(probe.get_publishers_info_by_topic(f'{NS}/actuators/state')),
                        timeout=10.0)
        time.sleep(0.5)  # let the subscriptions match before anything is sent
        replay.set_parameters([__import__('rclpy').parameter.Parameter('paused', value=False)])
        assert wait_for(lambda: (_status_of(statuses) or None) is not None
                        and _status_of(statuses).finished, timeout=20.0)
        time.sleep(0.3)
    status = _status_of(statuses)
    # /tf needs tf2_msgs (built by ./rrps when cmake and a C compiler are there)
    assert status.skipped == (() if importlib.util.find_spec('tf2_msgs') else ('/tf',))
    assert len(states) == 50  # the state stream is replayed as recorded (reliable)
    if allow:
        assert all(len(v) >= 25 for v in live.values())
        assert all(len(v) == 0 for v in moved.values()) and status.remapped == ()
    else:
        assert all(len(v) == 0 for v in live.values())  # nothing reached a driver
        assert all(len(v) >= 25 for v in moved.values())  # best effort: most of them
        assert set(status.remapped) == {f'{NS}/replay/{t}' for t in live}


def test_pause_seek_and_rate_through_parameters_and_the_status(ros_context, tmp_path):
    from diagnostic_msgs.msg import DiagnosticStatus
    from rclpy.parameter import Parameter

    probe = Probe(context=ros_context, namespace=NS)
    _, JointState, _ = _synthetic_recording(tmp_path / 'session.mcap', probe)
    states = probe.collect(JointState, 'actuators/state')
    statuses = probe.collect(DiagnosticStatus, 'replay/status')
    replay = _replay(ros_context, [tmp_path / 'session.mcap'], paused=True)
    with Spinner(ros_context, [replay, probe]):
        assert wait_for(lambda: len(statuses) >= 3)
        status = _status_of(statuses)
        assert status.paused and status.time == 0.0
        assert status.duration == pytest.approx(0.98)
        assert replay.published <= 4  # paused at the start: the first messages at most
        assert replay.set_parameters([Parameter('seek', value=0.5)])[0].successful
        n = len(statuses)
        assert wait_for(lambda: len(statuses) > n + 1)
        assert _status_of(statuses).time == pytest.approx(0.5)  # paused: stays there
        assert replay.set_parameters([Parameter('rate', value=0.5),
                                      Parameter('paused', value=False)])[0].successful
        assert wait_for(lambda: _status_of(statuses).finished)
        status = _status_of(statuses)
        assert status.rate == 0.5 and status.time == pytest.approx(status.duration)
        values = [round((s.position[0] - 0.43) * 1e4) for s in states]
        # from the seek on: the second half, in order
        assert values[-1] == 49 and values[-25:] == list(range(25, 50))
        assert replay.set_parameters([Parameter('seek', value=0.0)])[0].successful
        assert wait_for(lambda: _status_of(statuses).finished and len(states) >= len(values) + 50,
                        timeout=20.0)
    with pytest.raises(Exception):
        _replay(ros_context, [tmp_path / 'missing.mcap'])


def test_the_recorders_tf_is_replayed_as_tf2_msgs(ros_context, tmp_path):
    require(importlib.util.find_spec('tf2_msgs') is not None,
            'tf2_msgs is not installed (./rrps builds it when cmake and a C compiler are there)')
    from diagnostic_msgs.msg import DiagnosticStatus
    from tf2_msgs.msg import TFMessage

    from rrps_description.geometry import load_robot
    from rrps_description.pose import Pose
    from rrps_recording.markers import robot_frames
    from rrps_recording.robot_tf import TF_TYPE
    from rrps_recording.storage.mcap_files import TopicInfo, write_recording
    from rrps_recording.storage.qos import TF_QOS
    from rrps_runtime.cdr import tf_message_cdr
    from rrps_testing.transform_tree import pose_in
    a_T_b = Pose([0.0, 0.002, 0.43], [0.0, 0.0, math.sin(0.02), math.cos(0.02)])
    transforms = robot_frames(load_robot('pole_climber'), a_T_b, Pose([0.0, 0.0, 1.2]))
    t0 = time.time_ns()
    write_recording(tmp_path / 'tf.mcap', [TopicInfo('/tf', TF_TYPE, (TF_QOS,))],
                    [('/tf', t0 + i * 50_000_000, tf_message_cdr(t0 + i * 50_000_000, transforms))
                     for i in range(10)])  # the recorder's own /tf encoding
    probe = Probe(context=ros_context, namespace=NS)
    tf = probe.collect(TFMessage, '/tf')
    statuses = probe.collect(DiagnosticStatus, 'replay/status')
    replay = _replay(ros_context, [tmp_path / 'tf.mcap'], paused=True)
    with Spinner(ros_context, [replay, probe]):
        assert wait_for(lambda: probe.get_subscriptions_info_by_topic('/tf')
                        and probe.get_publishers_info_by_topic('/tf'))
        time.sleep(0.5)  # let the subscription match before anything is sent
        replay.set_parameters([__import__('rclpy').parameter.Parameter('paused', value=False)])
        assert wait_for(lambda: len(tf) == 10)
        assert wait_for(lambda: statuses and _status_of(statuses).finished)
    assert _status_of(statuses).skipped == ()
    last = {(t.header.frame_id, t.child_frame_id): t for t in tf[-1].transforms}
    assert set(last) == {(parent, child) for parent, child, _, _ in transforms}
    replayed = [(parent, child, Pose([t.translation.x, t.translation.y, t.translation.z],
                                     [t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w]))
                for (parent, child), msg in last.items() for t in (msg.transform,)]
    ring_b = pose_in(replayed, 'ring_b', 'ring_a')  # through leg 1's chain, as the URDF hangs it
    np.testing.assert_allclose(ring_b.position, a_T_b.position, atol=1e-12)
    np.testing.assert_allclose(ring_b.quaternion_xyzw, a_T_b.quaternion_xyzw, atol=1e-12)
    assert last[('odom', 'base_link')].transform.translation.z == 1.2


def test_clock_is_the_recordings_time_and_a_use_sim_time_node_follows_it(ros_context, tmp_path):
    """/clock (rosgraph_msgs/Clock) is the recording's time where the replay is: the first log
    time while paused at the start, never going back, through the recording as it plays, the last
    log time at its end. A node run with use_sim_time reads it as now: the recording was made a
    day ago, so its clock reads a day behind the wall clock, and stands still with the replay;
    the replay node itself, run with use_sim_time, stamps its /diagnostics in the recording's time
    (every rrps node takes now from its node clock) while it keeps playing at the wall's pace."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from rrps_recording.storage.mcap_files import TopicInfo, write_recording
    from rrps_recording.storage.qos import QosSpec
    from rrps_runtime.messages import joint_state_msg
    from rrps_runtime.qos import CLOCK_QOS

    t0 = time.time_ns() - 86_400 * 10**9
    log_times = [t0 + i * 20_000_000 for i in range(50)]
    write_recording(tmp_path / 'day_old.mcap', [TopicInfo(f'{NS}/actuators/state', 'sensor_msgs/msg/JointState',
                                                          (QosSpec(),))],
                    [(f'{NS}/actuators/state', t, serialize_message(joint_state_msg(JointState().header.stamp,
                                                                                    [0.43] * 6)))
                     for t in log_times])
    follower = Node('sim_time_follower', context=ros_context, namespace=NS,
                    parameter_overrides=[Parameter('use_sim_time', value=True)])
    ticks: list[int] = []
    follower.create_subscription(Clock, '/clock', lambda m: ticks.append(m.clock.sec * 10**9 + m.clock.nanosec),
                                 CLOCK_QOS)
    stamps: list[int] = []
    follower.create_subscription(DiagnosticArray, '/diagnostics', lambda m: stamps.extend(
        m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for s in m.status if 'replay' in s.name), 10)
    replay = _replay(ros_context, [tmp_path / 'day_old.mcap'], paused=True, clock_rate=50.0, use_sim_time=True)
    sim_now = lambda: follower.get_clock().now().nanoseconds  # noqa: E731
    with Spinner(ros_context, [replay, follower]):
        assert wait_for(lambda: len(ticks) >= 5 and sim_now() == t0, timeout=20.0)
        assert set(ticks) == {t0}                       # paused at the start: the clock stands
        assert abs(time.time_ns() - 86_400 * 10**9 - sim_now()) < 60 * 10**9
        n = len(ticks)
        replay.set_parameters([Parameter('paused', value=False)])
        assert wait_for(lambda: replay.finished and ticks[-1] == log_times[-1], timeout=30.0)
        assert wait_for(lambda: sim_now() == log_times[-1], timeout=10.0)
    playing = ticks[n:]
    assert all(b >= a for a, b in zip(ticks, ticks[1:]))  # never back
    assert min(ticks) == t0 and max(ticks) == log_times[-1]
    # it went through the recording, not in one jump: ticks at 50 Hz across its 0.98 s
    assert len({t for t in playing if t0 < t < log_times[-1]}) >= 5
    # before its first /clock a use_sim_time node's time is 0; after it, the recording's
    assert stamps and all(s == 0 or t0 <= s <= log_times[-1] for s in stamps) and max(stamps) >= t0, stamps
    follower.destroy_node()
