"""recorder_node over ROS: what it writes, read back with the mcap reader and mcap-ros2 decoder
(never with rrps' code): topics, schemas, counts against what was published, decoded values,
the QoS metadata, /tf, a file cut by a crash, and the flight recorder's dumps."""

from __future__ import annotations

import importlib.util
import os
import re
import secrets
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from mcap.reader import NonSeekingReader, make_reader
from mcap_ros2.decoder import DecoderFactory

from rrps_interfaces.status import source_node
from rrps_testing.ci import require
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

# A namespace of this run only: other ROS processes on the machine may share the domain id.
NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'


def _read(path: Path):
    """(summary, [(topic, schema name, decoded message, log time)]) of a closed file."""
    with open(path, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        messages = [(c.topic, s.name, d, m.log_time)
                     for s, c, m, d in reader.iter_decoded_messages()]
    return summary, messages


def _recorder(context, tmp_path, **params):
    from rclpy.parameter import Parameter

    from rrps_recording.nodes.recorder_node import RecorderNode
    overrides = {'output_dir': str(tmp_path), 'prefix': 'test', 'discovery_period': 0.1,
                 'flush_period': 0.2, **params}
    return RecorderNode(context=context, namespace=NS, parameter_overrides=[
        Parameter(k, value=v) for k, v in overrides.items()])


def _finished_dumps(folder: Path, kind: str) -> list[Path]:
    """The MCAP files of the finished flight-recorder bag folders of ``kind`` (``flight_<time>_<kind>``
    or ``..._<kind>_<n>``), never of a ``<folder>.part``, which may be renamed while it is listed."""
    pattern = re.compile(rf'flight_.+_{kind}(_\d+)?')
    return sorted(mcap for entry in folder.iterdir() if pattern.fullmatch(entry.name)
                  for mcap in entry.glob('*.mcap'))


def _pose(probe, z: float, frame='ring_a'):
    from rrps_runtime.messages import pose_to_msg
    return pose_to_msg([0.001, -0.002, z], [0.0, 0.0, 0.0, 1.0], frame_id=frame,
                       stamp=probe.get_clock().now().to_msg())


def test_recording_topics_schemas_counts_values_qos_and_tf(ros_context, tmp_path):
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool

    from rrps_description.pose import Pose
    from rrps_runtime.messages import joint_state_msg
    from rrps_testing.transform_tree import pose_in
    probe = Probe(context=ros_context, namespace=NS)
    pose_pub = probe.publisher(PoseStamped, 'pose')
    state_pub = probe.publisher(JointState, 'actuators/state')
    odom_pub = probe.publisher(PoseStamped, 'odometry/ring_a')
    recorder = _recorder(ros_context, tmp_path)
    poses, states = [], []
    with Spinner(ros_context, [recorder, probe]):
        assert wait_for(lambda: {f'{NS}/pose', f'{NS}/actuators/state', f'{NS}/odometry/ring_a'}
                        <= set(recorder._raw_subscriptions))
        # a publisher that appears after the recorder started (best effort, a command stream)
        enable_pub = probe.publisher(Bool, 'teleop/enable', command=True)
        assert wait_for(lambda: f'{NS}/teleop/enable' in recorder._raw_subscriptions)
        odom_pub.publish(_pose(probe, 1.5, frame='odom'))
        for i in range(200):
            msg = _pose(probe, 0.40 + 1e-4 * i)
            pose_pub.publish(msg)
            poses.append(msg)
            state = joint_state_msg(probe.get_clock().now().to_msg(),
                                    [0.4 + 1e-4 * i + 0.01 * k for k in range(6)],
                                    [0.0] * 6, [float(i)] * 6)
            state_pub.publish(state)
            states.append(state)
            if i % 10 == 0:
                enable_pub.publish(Bool(data=True))
            time.sleep(0.004)
        assert wait_for(lambda: recorder.recording.messages >= 400)
        time.sleep(0.3)
    summary, messages = _read(tmp_path / 'test' / 'test_0.mcap')
    channels = {c.topic: c for c in summary.channels.values()}
    schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert schemas[f'{NS}/pose'] == 'geometry_msgs/msg/PoseStamped'
    assert schemas[f'{NS}/actuators/state'] == 'sensor_msgs/msg/JointState'
    assert schemas[f'{NS}/teleop/enable'] == 'std_msgs/msg/Bool'
    assert schemas['/tf'] == 'tf2_msgs/msg/TFMessage'
    assert schemas['/diagnostics'] == 'diagnostic_msgs/msg/DiagnosticArray'
    assert all(summary.schemas[c.schema_id].encoding == 'ros2msg' for c in channels.values())
    assert all(c.message_encoding == 'cdr' for c in channels.values())
    # reliable publishers: every message, with the values published, in order
    recorded_poses = [d for t, _, d, _ in messages if t == f'{NS}/pose']
    assert len(recorded_poses) == len(poses)
    for got, sent in zip(recorded_poses, poses):
        assert (got.pose.position.z, got.header.stamp.sec, got.header.stamp.nanosec) == \
            (sent.pose.position.z, sent.header.stamp.sec, sent.header.stamp.nanosec)
        assert got.header.frame_id == 'ring_a'
    recorded_states = [d for t, _, d, _ in messages if t == f'{NS}/actuators/state']
    assert len(recorded_states) == len(states)
    for got, sent in zip(recorded_states, states):
        assert list(got.position) == list(sent.position) and list(got.effort) == list(sent.effort)
        assert list(got.name) == list(sent.name)
    counts = summary.statistics.channel_message_counts
    by_topic = {c.topic: counts.get(cid, 0) for cid, c in summary.channels.items()}
    assert by_topic[f'{NS}/pose'] == 200 and by_topic[f'{NS}/actuators/state'] == 200
    assert 1 <= by_topic[f'{NS}/teleop/enable'] <= 20  # best effort: none invented
    # the QoS each publisher offered, as rosbag2 writes it
    pose_qos = yaml.safe_load(channels[f'{NS}/pose'].metadata['offered_qos_profiles'])
    assert pose_qos[0]['reliability'] == 'reliable' and pose_qos[0]['durability'] == 'volatile'
    assert set(pose_qos[0]) == {'history', 'depth', 'reliability', 'durability', 'deadline',
                                'lifespan', 'liveliness', 'liveliness_lease_duration',
                                'avoid_ros_namespace_conventions'}
    enable_qos = yaml.safe_load(channels[f'{NS}/teleop/enable'].metadata['offered_qos_profiles'])
    assert enable_qos[0]['reliability'] == 'best_effort'
    assert channels[f'{NS}/pose'].metadata['topic_type_hash'].startswith('RIHS01_')
    with open(tmp_path / 'test' / 'test_0.mcap', 'rb') as stream:
        [bag] = [m for m in make_reader(stream).iter_metadata() if m.name == 'rosbag2']
    meta = yaml.safe_load(bag.metadata['serialized_metadata'])
    assert meta['version'] == 9 and meta['message_count'] == summary.statistics.message_count
    # /tf: world -> ring_a from the odometry, ring_a -> ring_b the last pose
    tf = [d for t, _, d, _ in messages if t == '/tf']
    assert tf
    last = {(x.header.frame_id, x.child_frame_id): x.transform for x in tf[-1].transforms}
    assert last[('odom', 'base_link')].translation.z == pytest.approx(1.5)
    # the URDF's tree, fixed joints included (any part of a recording shows the whole robot)
    tree = [(parent, child, Pose([t.translation.x, t.translation.y, t.translation.z],
                                 [t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w]))
            for (parent, child), t in last.items()]
    assert pose_in(tree, 'ring_b', 'ring_a').position[2] == pytest.approx(poses[-1].pose.position.z)
    assert {('ring_a', f'leg_{i}_universal_cross') for i in range(1, 7)} <= set(last)
    assert {(f'leg_{i}_spherical_x_link', f'leg_{i}_tip') for i in range(1, 7)} <= set(last)
    assert ('leg_1_tip', 'ring_b') in last
    # the recorder reports on /diagnostics (recorded too), with its host role as hardware_id
    diag = [s for t, _, d, _ in messages if t == '/diagnostics' for s in d.status]
    assert any(source_node(s.name) == 'recorder_node' and s.hardware_id == 'observer' for s in diag)
    # the bag folder as rosbags (an independent rosbag2 reader) sees it
    _check_bag_with_rosbags(tmp_path / 'test', summary, poses)


def _check_bag_with_rosbags(folder: Path, summary, poses) -> None:
    """metadata.yaml agrees with the MCAP summary; rosbags reads topics, types, counts, time
    range, QoS and the published poses."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    counts = summary.statistics.channel_message_counts
    expected = {c.topic: (summary.schemas[c.schema_id].name, counts.get(cid, 0))
                for cid, c in summary.channels.items()}
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(folder) as reader:
        assert reader.ros_distro == 'jazzy'
        assert {c.topic: (c.msgtype, c.msgcount) for c in reader.connections} == expected
        assert reader.message_count == summary.statistics.message_count
        assert (reader.start_time, reader.end_time - 1) == (summary.statistics.message_start_time,
                                                            summary.statistics.message_end_time)
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        assert [q.reliability.name for q in qos[f'{NS}/teleop/enable']] == ['BEST_EFFORT']
        assert [q.reliability.name for q in qos[f'{NS}/pose']] == ['RELIABLE']
        pose_connection = [c for c in reader.connections if c.topic == f'{NS}/pose']
        zs = [store.deserialize_cdr(data, c.msgtype).pose.position.z
              for c, _, data in reader.messages(connections=pose_connection)]
    assert zs == [p.pose.position.z for p in poses]


def test_with_a_live_tf_the_recorder_writes_its_own_tf_only(ros_context, tmp_path):
    """markers_node publishes live /tf and /tf_static: a recorder that writes /tf (tf_rate > 0)
    subscribes to neither (no duplicate transforms); one at tf_rate 0 records both, and they agree
    (the recorder's /tf also has the URDF's fixed joints, which markers_node puts on /tf_static)."""
    require(importlib.util.find_spec('tf2_msgs') is not None,
            'tf2_msgs is not installed (./rrps builds it when cmake and a C compiler are there)')
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter

    from rrps_description.geometry import load_robot
    from rrps_recording.markers import fixed_transforms
    from rrps_recording.nodes.markers_node import MarkersNode
    from rrps_recording.nodes.recorder_node import RecorderNode
    probe = Probe(context=ros_context, namespace=NS)
    markers = MarkersNode(context=ros_context, namespace=NS,
                          parameter_overrides=[Parameter('tf_rate', value=100.0)])
    own = _recorder(ros_context, tmp_path / 'own')
    live = RecorderNode(context=ros_context, namespace=NS, cli_args=[
        '--ros-args', '-r', '__node:=recorder_live'], parameter_overrides=[
        Parameter(k, value=v) for k, v in {'output_dir': str(tmp_path / 'live'), 'prefix': 'test',
                                           'discovery_period': 0.1, 'flush_period': 0.2,
                                           'tf_rate': 0.0, 'flight_recorder': False}.items()])
    pose_pub = probe.publisher(PoseStamped, 'pose')
    odom_pub = probe.publisher(PoseStamped, 'odometry/ring_a')
    with Spinner(ros_context, [markers, own, live, probe]):
        assert wait_for(lambda: probe.count_subscribers(f'{NS}/pose') >= 3
                        and probe.count_subscribers(f'{NS}/odometry/ring_a') >= 3)
        odom_pub.publish(_pose(probe, 1.5, frame='odom'))
        pose_pub.publish(_pose(probe, 0.42))
        assert wait_for(lambda: {'/tf', '/tf_static'} <= set(live._raw_subscriptions))
        seen = own.messages
        assert wait_for(lambda: own.messages > seen + 20 and markers.tf_published > 100,
                        timeout=20.0)
        subscribers = {i.node_name for i in probe.get_subscriptions_info_by_topic('/tf')}
        for topic in ('/tf', '/tf_static'):
            assert topic not in own._raw_subscriptions and topic not in own.dropped_topics
    assert subscribers == {'recorder_live'}
    tf = {}
    for name in ('own', 'live'):
        summary, messages = _read(tmp_path / name / 'test' / 'test_0.mcap')
        [channel] = [c for c in summary.channels.values() if c.topic == '/tf']
        [offered] = yaml.safe_load(channel.metadata['offered_qos_profiles'])
        assert (offered['reliability'], offered['durability']) == ('reliable', 'volatile')
        tf[name] = [(t, d) for topic, _, d, t in messages if topic == '/tf']
        static = [d for topic, _, d, _ in messages if topic == '/tf_static']
    assert len(static) == 1  # latched: the one message markers_node sent before the recorder joined
    # own: the recorder's 10 Hz only, not the live 100 Hz as well
    span = (tf['own'][-1][0] - tf['own'][0][0]) * 1e-9
    assert len(tf['own']) <= 10.0 * span + 3
    assert len(tf['live']) > len(tf['own'])
    frames = [{(x.header.frame_id, x.child_frame_id): x.transform for x in d.transforms}
              for d in (tf['own'][-1][1], tf['live'][-1][1])]
    fixed = {(parent, child) for parent, child, _ in fixed_transforms(load_robot('pole_climber'))}
    assert frames[0].keys() == frames[1].keys() | fixed and ('odom', 'base_link') in frames[1]
    assert not frames[1].keys() & fixed
    assert {(x.header.frame_id, x.child_frame_id) for x in static[0].transforms} == fixed
    for key, b in frames[1].items():
        a = frames[0][key]
        assert [a.translation.x, a.translation.y, a.translation.z, a.rotation.x, a.rotation.y,
                a.rotation.z, a.rotation.w] == pytest.approx(
            [b.translation.x, b.translation.y, b.translation.z, b.rotation.x, b.rotation.y,
             b.rotation.z, b.rotation.w], abs=1e-12), key


def test_a_recording_cut_by_a_crash_is_readable_up_to_the_crash(ros_context, ros_domain_id,
                                                                  tmp_path):
    """SIGKILL the recorder process: what it flushed (every flush_period) stays readable."""
    from geometry_msgs.msg import PoseStamped

    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id))
    child = subprocess.Popen(
        [sys.executable, '-m', 'rrps_recording.nodes.recorder_node', '--ros-args', '-r',
         f'__ns:={NS}', '-p', f'output_dir:={tmp_path}', '-p', 'prefix:=crash', '-p',
         'flush_period:=0.2', '-p', 'discovery_period:=0.1', '-p', 'flight_recorder:=false',
         '-p', 'tf_rate:=0.0'], env=env)
    probe = Probe(context=ros_context, namespace=NS)
    pub = probe.publisher(PoseStamped, 'pose')
    rate = 100.0
    try:
        with Spinner(ros_context, [probe]):
            assert wait_for(lambda: pub.get_subscription_count() > 0)
            time.sleep(0.5)
            sent = 0
            t_end = time.monotonic() + 2.0
            while time.monotonic() < t_end:
                pub.publish(_pose(probe, 0.4 + 1e-5 * sent))
                sent += 1
                time.sleep(1.0 / rate)
            time.sleep(0.1)
            child.send_signal(signal.SIGKILL)
            child.wait(timeout=10.0)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    path = tmp_path / 'crash' / 'crash_0.mcap'
    zs = []
    with open(path, 'rb') as stream:
        try:
            reader = NonSeekingReader(stream, decoder_factories=[DecoderFactory()])
            for _, channel, _, decoded in reader.iter_decoded_messages(log_time_order=False):
                if channel.topic == f'{NS}/pose':
                    zs.append(round((decoded.pose.position.z - 0.4) * 1e5))
        except Exception:  # the end of the file is cut: no summary, maybe half a record
            pass
    assert zs == list(range(len(zs)))  # what is there is whole and in order
    # lost: at most what came after the last flush (flush_period 0.2 s) and the last 0.1 s
    assert len(zs) >= sent - rate * 1.0, (len(zs), sent)
    # the bag: metadata.yaml lists the files closed before the crash (none here); the cut
    # file stays in the folder, and a replay of the folder reads it
    from rrps_recording.storage.bag import bag_files
    from rrps_recording.transport.replay import RecordingSet
    meta = yaml.safe_load((tmp_path / 'crash' / 'metadata.yaml').read_text())
    assert meta['rosbag2_bagfile_information']['relative_file_paths'] == []
    assert bag_files(tmp_path / 'crash') == [path]
    replayed = RecordingSet([tmp_path / 'crash']).messages(topics=[f'{NS}/pose'])
    assert sum(1 for _ in replayed) == len(zs)


def _trigger(client, node, timeout=10.0):
    from std_srvs.srv import Trigger
    assert client.wait_for_service(timeout_sec=timeout)
    future = client.call_async(Trigger.Request())
    assert wait_for(future.done, timeout=timeout)
    return future.result()


def test_flight_recorder_saves_on_request_and_on_faults(ros_context, tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from geometry_msgs.msg import PoseStamped
    from std_srvs.srv import Trigger

    from rrps_interfaces.driver import DriverStatus
    from rrps_interfaces.recording import FLIGHT_RECORDER_SAVE
    probe = Probe(context=ros_context, namespace=NS)
    pose_pub = probe.publisher(PoseStamped, 'pose')
    diag_pub = probe.publisher(DiagnosticArray, '/diagnostics')
    teleop_pub = probe.publisher(DiagnosticStatus, 'teleop/status')
    client = probe.create_client(Trigger, FLIGHT_RECORDER_SAVE)
    recorder = _recorder(ros_context, tmp_path, record=False, buffer_seconds=1.0,
                         post_trigger=0.1, min_dump_interval=0.0, tf_rate=0.0)

    def driver(refusals, level=DiagnosticStatus.OK):
        status = DiagnosticStatus(level=level, name='driver_node: kinematic actuators')
        status.values = [KeyValue(key=k, value=v)
                         for k, v in DriverStatus(gripper_refusals=refusals).to_values().items()]
        return DiagnosticArray(status=[status])

    def dumps(kind):
        return _finished_dumps(tmp_path, kind)

    with Spinner(ros_context, [recorder, probe]):
        assert wait_for(lambda: f'{NS}/pose' in recorder._raw_subscriptions)
        for i in range(300):  # 3 s at 100 Hz: the 1 s window keeps the last ~100
            pose_pub.publish(_pose(probe, 0.4 + 1e-5 * i))
            time.sleep(0.01)
        response = _trigger(client, probe)
        assert response.success
        path = Path(response.message)
        # the MCAP file of the bag folder <output_dir>/flight_<time>_operator/
        assert path.parent.parent == tmp_path.resolve() and path.name == f'{path.parent.name}_0.mcap'
        assert 'operator' in path.name
        assert wait_for(path.exists)
        assert (path.parent / 'metadata.yaml').is_file()
        _, messages = _read(path)
        zs = [round((d.pose.position.z - 0.4) * 1e5) for t, _, d, _ in messages
              if t == f'{NS}/pose']
        assert zs and zs[-1] == 299 and zs == list(range(zs[0], 300))
        # the 1 s window (and the 0.1 s after the trigger), not the whole 3 s: judged by the
        # receipt times, since a starved process published 38 poses in its last second, not 100
        received = [log_time for t, _, _, log_time in messages if t == f'{NS}/pose']
        assert zs[0] > 0 and (max(received) - min(received)) * 1e-9 <= 1.0 + 0.1 + 0.05, (zs[0], received)
        assert not list(tmp_path.glob('test*'))  # record:=false writes no recording
        # from here on the pose streams on, so that every fault's window holds poses however
        # long the machine takes between one fault and the next
        probe.create_timer(0.02, lambda: pose_pub.publish(_pose(probe, 0.5)))
        # a gripper refusal (the driver's typed count goes up)
        diag_pub.publish(driver(0))
        assert wait_for(lambda: recorder._faults._refusals == 0)
        diag_pub.publish(driver(1))
        assert wait_for(lambda: dumps('gripper_refusal'))
        # a node at ERROR
        diag_pub.publish(DiagnosticArray(status=[DiagnosticStatus(
            level=DiagnosticStatus.ERROR, name='fk_node: forward kinematics')]))
        assert wait_for(lambda: dumps('node_error'))
        # a lost teleop link: healthy, then STALE
        teleop_pub.publish(DiagnosticStatus(level=DiagnosticStatus.OK, name='teleop_node: teleop'))
        time.sleep(0.3)
        teleop_pub.publish(DiagnosticStatus(level=DiagnosticStatus.STALE,
                                            name='teleop_node: teleop'))
        assert wait_for(lambda: dumps('link_lost'))
        recorder.wait_for_dumps()
    for kind in ('gripper_refusal', 'node_error', 'link_lost'):
        for path in dumps(kind):  # (another process on this domain may add a fault)
            _, messages = _read(path)
            assert any(t == f'{NS}/pose' for t, _, _, _ in messages)
    assert not list(tmp_path.glob('*.part'))


def test_faults_trigger_a_dump_also_when_their_topics_are_not_recorded(ros_context, tmp_path):
    """The fault triggers' topics are heard through the recording's own subscription when they
    are recorded, through one of their own when they are not (here only pose is recorded)."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from geometry_msgs.msg import PoseStamped
    probe = Probe(context=ros_context, namespace=NS)
    pose_pub = probe.publisher(PoseStamped, 'pose')
    diag_pub = probe.publisher(DiagnosticArray, '/diagnostics')
    recorder = _recorder(ros_context, tmp_path, record=False, topics=[f'{NS}/pose'],
                         post_trigger=0.1, min_dump_interval=0.0, tf_rate=0.0)
    with Spinner(ros_context, [recorder, probe]):
        assert wait_for(lambda: f'{NS}/pose' in recorder._raw_subscriptions)
        assert '/diagnostics' not in recorder._raw_subscriptions
        assert wait_for(lambda: diag_pub.get_subscription_count() >= 1)
        for i in range(20):
            pose_pub.publish(_pose(probe, 0.4 + 1e-5 * i))
            time.sleep(0.01)
        diag_pub.publish(DiagnosticArray(status=[DiagnosticStatus(
            level=DiagnosticStatus.ERROR, name='fk_node: forward kinematics')]))
        assert wait_for(lambda: _finished_dumps(tmp_path, 'node_error'))
        recorder.wait_for_dumps()
    path, = _finished_dumps(tmp_path, 'node_error')
    _, messages = _read(path)
    assert {t for t, _, _, _ in messages} == {f'{NS}/pose'}
