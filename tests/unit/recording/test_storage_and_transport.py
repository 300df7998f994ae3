"""The recording core without ROS nodes: schemas, QoS metadata, MCAP files, ring, triggers,
replay timing and remap, marker and TF geometry.

Files are always read back with the ``mcap`` reader and mcap-ros2-support's decoder, never with
rrps' own code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rrps_interfaces.recording import COMMAND_TOPICS, RecorderTrigger
from rrps_recording.storage.bag import BagRecording
from rrps_recording.storage.mcap_files import McapRecording, TopicInfo, write_recording
from rrps_recording.storage.qos import (
    INFINITE_NS,
    QosSpec,
    offer_for_replay,
    offered_qos_yaml,
    parse_offered_qos,
    request_for_offers,
)
from rrps_recording.storage.schemas import SEPARATOR, dependencies, message_schema, type_hash
from rrps_recording.transport.replay import RecordingSet, ReplayClock, is_command_topic, replay_topic
from rrps_recording.transport.ring import MessageRing
from rrps_recording.transport.triggers import ERROR, OK, STALE, WARN, FaultWatch, StatusEvent


def _messages():
    """One message of every type the stack publishes, with non-default values."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool
    from visualization_msgs.msg import Marker, MarkerArray

    pose = PoseStamped()
    pose.header.frame_id = 'ring_a'
    pose.header.stamp.sec, pose.header.stamp.nanosec = 12, 345
    pose.pose.position.x, pose.pose.position.z = 0.01, 0.42
    pose.pose.orientation.z, pose.pose.orientation.w = math.sin(0.1), math.cos(0.1)
    state = JointState(name=[f'leg_{i}' for i in range(1, 7)], position=[0.4 + 0.01 * i for i in range(6)],
                       velocity=[0.001 * i for i in range(6)], effort=[10.0 * i for i in range(6)])
    status = DiagnosticStatus(level=DiagnosticStatus.ERROR, name='driver_node: dynamic actuators',
                              message='m', hardware_id='h',
                              values=[KeyValue(key='gripper_refusals', value='3')])
    marker = Marker(ns='legs', id=2, type=Marker.LINE_LIST)
    marker.points = [type(pose.pose.position)(x=1.0, y=2.0, z=3.0)]
    return {
        'geometry_msgs/msg/PoseStamped': pose,
        'sensor_msgs/msg/JointState': state,
        'diagnostic_msgs/msg/DiagnosticArray': DiagnosticArray(status=[status]),
        'diagnostic_msgs/msg/DiagnosticStatus': status,
        'std_msgs/msg/Bool': Bool(data=True),
        'visualization_msgs/msg/MarkerArray': MarkerArray(markers=[marker]),
    }


def _plain(value):
    """A ROS message (rclpy or mcap-ros2 decoded) as nested plain Python values."""
    if hasattr(value, 'get_fields_and_field_types'):
        return {k: (getattr(value, k)[0] if kind == 'octet' else _plain(getattr(value, k)))
                for k, kind in value.get_fields_and_field_types().items()}
    if hasattr(value, '__slots__') and not isinstance(value, (bytes, str)):
        return {k: _plain(getattr(value, k)) for k in value.__slots__ if not k.startswith('_')}
    import array
    if isinstance(value, (list, tuple, np.ndarray, bytes, bytearray, array.array)) \
            and not isinstance(value, str):
        if isinstance(value, (bytes, bytearray)):
            return list(value)
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def _decoded(path):
    with open(path, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [(channel.topic, schema.name, message, decoded)
                for schema, channel, message, decoded in reader.iter_decoded_messages()]


def test_schemas_of_every_stack_type_decode_rclpy_bytes_to_the_same_values(tmp_path):
    from rclpy.serialization import serialize_message

    messages = _messages()
    topics = [TopicInfo(f'/t{i}', name) for i, name in enumerate(messages)]
    path = write_recording(tmp_path / 'all.mcap', topics,
                           [(f'/t{i}', 1000 + i, serialize_message(m))
                            for i, m in enumerate(messages.values())])
    decoded = {schema: value for _, schema, _, value in _decoded(path)}
    assert set(decoded) == set(messages)
    for name, original in messages.items():
        assert _plain(decoded[name]) == _plain(original), name


def test_schema_text_concatenates_dependencies_as_rosbag2_does():
    text = message_schema('geometry_msgs/msg/PoseStamped')
    blocks = text.split('\n' + SEPARATOR + '\n')
    assert blocks[0].splitlines()[-2:] == ['std_msgs/Header header', 'Pose pose'] or \
        'Pose pose' in blocks[0]
    names = [b.splitlines()[0] for b in blocks[1:]]
    assert names == ['MSG: std_msgs/Header', 'MSG: builtin_interfaces/Time', 'MSG: geometry_msgs/Pose',
                     'MSG: geometry_msgs/Point', 'MSG: geometry_msgs/Quaternion']
    assert dependencies('geometry_msgs/msg/PoseStamped') == [
        'std_msgs/msg/Header', 'builtin_interfaces/msg/Time', 'geometry_msgs/msg/Pose',
        'geometry_msgs/msg/Point', 'geometry_msgs/msg/Quaternion']
    assert type_hash('geometry_msgs/msg/PoseStamped').startswith('RIHS01_')


def test_a_type_rosbags_does_not_know_is_read_from_its_installed_msg_file(tmp_path):
    """nav_msgs/Goals is installed but not in rosbags' Jazzy typestore: its schema comes from the
    .msg files, decodes rclpy's bytes, and its hash is the installed type description's."""
    import json
    import sys
    from pathlib import Path

    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Goals
    from rclpy.serialization import serialize_message

    name = 'nav_msgs/msg/Goals'
    goal = PoseStamped()
    goal.header.frame_id, goal.pose.position.x, goal.pose.orientation.w = 'map', 2.5, 1.0
    message = Goals(goals=[goal, goal])
    message.header.frame_id = 'map'
    path = write_recording(tmp_path / 'goals.mcap', [TopicInfo('/goals', name)],
                           [('/goals', 7, serialize_message(message))])
    [(_, schema, _, value)] = _decoded(path)
    assert schema == name and _plain(value) == _plain(message)
    description = json.loads((Path(sys.prefix) / 'share/nav_msgs/msg/Goals.json').read_text())
    assert type_hash(name) == next(h['hash_string'] for h in description['type_hashes'] if h['type_name'] == name)


def test_tf_schema_without_tf2_msgs_encodes_and_decodes(tmp_path):
    from mcap_ros2._dynamic import serialize_dynamic

    name = 'tf2_msgs/msg/TFMessage'
    encode = serialize_dynamic(name, message_schema(name))[name]
    tf = {'transforms': [{'header': {'stamp': {'sec': 1, 'nanosec': 2}, 'frame_id': 'world'},
                          'child_frame_id': 'ring_a',
                          'transform': {'translation': {'x': 1.0, 'y': 2.0, 'z': 3.0},
                                        'rotation': {'x': 0.0, 'y': 0.0, 'z': 0.0, 'w': 1.0}}}]}
    path = write_recording(tmp_path / 'tf.mcap', [TopicInfo('/tf', name)], [('/tf', 5, encode(tf))])
    [(topic, schema, _, value)] = _decoded(path)
    assert (topic, schema) == ('/tf', name)
    t = value.transforms[0]
    assert (t.header.frame_id, t.child_frame_id, t.transform.translation.z) == ('world', 'ring_a', 3.0)


@settings(max_examples=100, deadline=None)
@given(stamp=st.integers(0, (2**31 - 1) * 1_000_000_000), transforms=st.lists(st.tuples(
    st.text(max_size=12), st.text(max_size=12),
    st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3),
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
        lambda q: sum(v * v for v in q) > 0.1)), max_size=14))
def test_the_recorder_tf_encoding_is_mcap_ros2s_byte_for_byte(stamp, transforms):
    from mcap_ros2._dynamic import serialize_dynamic

    from rrps_description.pose import Pose
    from rrps_runtime.cdr import tf_message_cdr
    name = 'tf2_msgs/msg/TFMessage'
    encode = serialize_dynamic(name, message_schema(name))[name]
    poses = [(parent, child, Pose(p, q)) for parent, child, p, q in transforms]
    sec, nanosec = divmod(stamp, 1_000_000_000)
    reference = encode({'transforms': [
        {'header': {'stamp': {'sec': sec, 'nanosec': nanosec}, 'frame_id': parent},
         'child_frame_id': child,
         'transform': {'translation': dict(zip('xyz', map(float, pose.position))),
                       'rotation': dict(zip('xyzw', map(float, pose.quaternion_xyzw)))}}
        for parent, child, pose in poses]})
    assert tf_message_cdr(stamp, [(parent, child, pose.position, pose.quaternion_xyzw)
                                  for parent, child, pose in poses]) == reference


def test_offered_qos_yaml_is_rosbag2_jazzy_text_and_reads_back():
    reliable = QosSpec(depth=10)
    best_effort = QosSpec(depth=1, reliability=2, durability=2, deadline_ns=1_500_000_000)
    text = offered_qos_yaml([reliable, best_effort])
    assert text.splitlines()[:6] == ['- history: keep_last', '  depth: 10', '  reliability: reliable',
                                     '  durability: volatile', '  deadline:', '    sec: 9223372036']
    data = yaml.safe_load(text)
    assert data[1]['reliability'] == 'best_effort'
    assert data[1]['deadline'] == {'sec': 1, 'nsec': 500_000_000}
    assert data[0]['liveliness_lease_duration'] == {'sec': 9223372036, 'nsec': 854775807}
    assert data[0]['avoid_ros_namespace_conventions'] is False
    assert parse_offered_qos(text) == [reliable, best_effort]
    # bags of metadata version <= 8 wrote the enum numbers
    numbers = text.replace('keep_last', '1').replace('best_effort', '2').replace('reliable', '1') \
        .replace('volatile', '2').replace('automatic', '1')
    assert parse_offered_qos(numbers) == [reliable, best_effort]
    assert offered_qos_yaml([]) == '[]' and parse_offered_qos('[]') == []
    with pytest.raises(ValueError):
        parse_offered_qos('- history: sometimes')
    assert INFINITE_NS == 9223372036 * 10**9 + 854775807


def test_recorder_and_replay_qos_follow_the_publishers():
    reliable, best_effort = QosSpec(), QosSpec(reliability=2)
    latched = QosSpec(durability=1)
    assert request_for_offers([reliable, reliable]).reliability == 1
    assert request_for_offers([reliable, best_effort]).reliability == 2  # hears both
    assert request_for_offers([latched]).durability == 1
    assert request_for_offers([latched, reliable]).durability == 2
    assert offer_for_replay([best_effort]).reliability == 2
    assert offer_for_replay([latched, latched]).durability == 1
    assert offer_for_replay([reliable, best_effort]) == QosSpec(depth=10)


def test_rotation_by_duration_and_by_size_and_bag_metadata(tmp_path):
    topic = TopicInfo('/rrps/x', 'std_msgs/msg/Bool')
    by_time = BagRecording(tmp_path / 'time' / 'r', max_seconds=1.0)
    by_time.add_topic(topic)
    for i in range(30):  # 3 s of 10 Hz
        by_time.write('/rrps/x', 10**9 * 100 + i * 10**8, b'\x00\x01\x00\x00\x01')
    by_time.close()
    assert [p.name for p in by_time.files] == ['r_0.mcap', 'r_1.mcap', 'r_2.mcap']
    counts = [len(_decoded(p)) for p in by_time.files]
    assert counts == [10, 10, 10]
    by_size = BagRecording(tmp_path / 'size' / 'r', max_bytes=20_000, compression='none', chunk_size=4096)
    by_size.add_topic(topic)
    for i in range(3000):
        by_size.write('/rrps/x', i, b'\x00\x01\x00\x00' + bytes([i % 2]) + bytes(60))
    by_size.close()
    assert len(by_size.files) > 2
    assert sum(len(_decoded(p)) for p in by_size.files) == 3000
    with open(by_time.files[1], 'rb') as stream:
        reader = make_reader(stream)
        [record] = [m for m in reader.iter_metadata() if m.name == 'rosbag2']
    bag = yaml.safe_load(record.metadata['serialized_metadata'])
    assert bag['version'] == 9 and bag['storage_identifier'] == 'mcap'
    assert bag['ros_distro'] == 'jazzy' and bag['message_count'] == 10
    assert bag['relative_file_paths'] == ['r_1.mcap']  # each file is a bag by itself too
    [entry] = bag['topics_with_message_count']
    assert entry['message_count'] == 10
    assert entry['topic_metadata']['type'] == 'std_msgs/msg/Bool'
    assert entry['topic_metadata']['serialization_format'] == 'cdr'
    for key in ('duration', 'starting_time', 'compression_format', 'compression_mode', 'files',
                'custom_data'):
        assert key in bag


def test_a_file_that_was_never_closed_is_readable_up_to_its_last_flush(tmp_path):
    from mcap.reader import NonSeekingReader

    path = tmp_path / 'cut.mcap'
    recording = McapRecording(path, flush_period=0.5)
    recording.add_topic(TopicInfo('/x', 'std_msgs/msg/Bool'))
    for i in range(100):  # 10 s at 10 Hz, flushed every 0.5 s of log time
        recording.write('/x', i * 10**8, b'\x00\x01\x00\x00' + bytes([i % 2]))
    # no close(): as if the process died here
    got = []
    with open(path, 'rb') as stream:
        try:
            # file order: a log-time ordered read would first need the (missing) end
            for _, _, message in NonSeekingReader(stream).iter_messages(log_time_order=False):
                got.append(message.log_time)
        except Exception:  # the cut: the reader stops at the incomplete end
            pass
    assert got == [i * 10**8 for i in range(len(got))]
    assert len(got) >= 100 - 6  # at most the last 0.5 s (+1 message) is lost
    recording.close()
    assert len(_decoded(path)) == 100
    replay = RecordingSet([path])
    assert replay.topics['/x'].message_count == 100


def test_message_ring_keeps_the_window_and_bounds_memory():
    ring = MessageRing(1.0)
    for i in range(300):  # 3 s at 100 Hz
        ring.add('/a', i * 10**7, b'x' * 10)
    times = [t for _, t, _ in ring.snapshot()]
    assert times[0] == 199 * 10**7 and times[-1] == 299 * 10**7
    assert ring.span == pytest.approx(1.0) and ring.nbytes == 10 * len(times)
    small = MessageRing(60.0, max_bytes=1000)
    for i in range(500):
        small.add('/a', i, b'y' * 10)
    assert small.nbytes <= 1000 and len(small) == 100 and small.dropped_for_memory == 400
    with pytest.raises(ValueError):
        MessageRing(0.0)


def _driver(refusals: int, level: int = OK) -> StatusEvent:
    from rrps_interfaces.driver import DriverStatus
    return StatusEvent('/diagnostics', level, 'driver_node: kinematic actuators',
                       DriverStatus(gripper_refusals=refusals).to_values())


def test_fault_triggers_fire_once_per_fault():
    watch = FaultWatch()
    assert watch.check(_driver(0)) is None
    assert watch.check(_driver(0)) is None
    assert watch.check(_driver(1)) is RecorderTrigger.GRIPPER_REFUSAL
    assert watch.check(_driver(1)) is None
    fk = StatusEvent('/diagnostics', ERROR, 'fk_node: forward kinematics', {})
    assert watch.check(fk) is RecorderTrigger.NODE_ERROR
    assert watch.check(fk) is None  # still the same fault
    assert watch.check(StatusEvent('/diagnostics', OK, fk.name, {})) is None
    assert watch.check(fk) is RecorderTrigger.NODE_ERROR  # a new fault
    assert watch.check(StatusEvent('/diagnostics', WARN, 'ik_node: x', {})) is None
    # teleop/status STALE at start-up (waiting for its inputs) is not a lost link...
    assert watch.check(StatusEvent('teleop/status', STALE, 'teleop_node: teleop', {})) is None
    assert watch.check(StatusEvent('teleop/status', OK, 'teleop_node: teleop', {})) is None
    # ...STALE after being healthy is
    assert watch.check(StatusEvent('teleop/status', STALE, 'teleop_node: teleop', {})) \
        is RecorderTrigger.LINK_LOST
    assert watch.check(StatusEvent('climb/status', ERROR, 'climb_node: climb', {})) \
        is RecorderTrigger.LINK_LOST
    # another node's malformed values are not a refusal
    assert watch.check(StatusEvent('/diagnostics', OK, 'driver_node: x',
                                   {'gripper_refusals': 'many'})) is None


def test_replay_clock_rate_pause_seek():
    clock = ReplayClock(10 * 10**9, 20 * 10**9, now=100.0)
    assert clock.position(101.0) == 11 * 10**9
    assert clock.wait(12 * 10**9, 101.0) == pytest.approx(1.0)
    clock.set_rate(2.0, 101.0)
    assert clock.position(102.0) == 13 * 10**9
    assert clock.wait(15 * 10**9, 102.0) == pytest.approx(1.0)
    clock.set_paused(True, 102.0)
    assert clock.position(150.0) == 13 * 10**9 and clock.wait(14 * 10**9, 150.0) == math.inf
    epoch = clock.epoch
    clock.seek(18 * 10**9, 150.0)
    assert clock.epoch == epoch + 1 and clock.elapsed(160.0) == pytest.approx(8.0)
    assert clock.read_from == 18 * 10**9
    clock.set_paused(False, 160.0)
    assert clock.position(200.0) == 20 * 10**9  # clamped at the end
    clock.seek(0, 200.0)
    assert clock.position(200.0) == 10 * 10**9
    with pytest.raises(ValueError):
        clock.set_rate(0.0, 0.0)


def test_command_topics_are_remapped_unless_allowed():
    assert replay_topic('/rrps/target_pose') == '/rrps/replay/target_pose'
    assert replay_topic('/rrps/master/target_pose') == '/rrps/replay/master/target_pose'
    assert replay_topic('/rrps/actuators/command') == '/rrps/replay/actuators/command'
    assert replay_topic('/rrps/teleop/enable') == '/rrps/replay/teleop/enable'
    assert replay_topic('/target_pose') == '/replay/target_pose'
    assert replay_topic('/rrps/actuators/state') == '/rrps/actuators/state'
    assert replay_topic('/rrps/pose') == '/rrps/pose'
    assert replay_topic('/rrps/target_pose', allow_commands=True) == '/rrps/target_pose'
    assert all(is_command_topic(f'/rrps/{c}') for c in COMMAND_TOPICS)
    assert not is_command_topic('/rrps/teleop/status')


def test_transforms_chain_to_the_joint_centres_and_markers_use_the_viewer_colours():
    from rrps_description.geometry import load_robot
    from rrps_description.pose import Pose
    from rrps_description.urdf import leg_chain
    from rrps_kinematics.inverse import inverse_kinematics
    from rrps_kinematics.scene import robot_figure
    from rrps_recording.markers import fixed_transforms, robot_markers, robot_transforms
    from rrps_testing.transform_tree import pose_in

    geom = load_robot('pole_climber')
    a_T_b = Pose([0.01, -0.005, 0.42], [math.sin(0.05), 0.0, 0.0, math.cos(0.05)])
    world_T_a = Pose([0.0, 0.0, 1.2], [0.0, 0.0, math.sin(0.3), math.cos(0.3)])
    tree = robot_transforms(geom, a_T_b, world_T_a)
    moving = robot_transforms(geom, a_T_b, world_T_a, fixed=False)
    # the fixed joints are robot_state_publisher's /tf_static: the whole tree is the two
    assert sorted(tree, key=repr) == sorted(moving + fixed_transforms(geom), key=repr)
    assert ('leg_1_tip', 'ring_b') in {(p, c) for p, c, _ in fixed_transforms(geom)}

    ik = inverse_kinematics(geom, a_T_b.position, a_T_b.quaternion_xyzw)
    for i in range(6):
        chain = leg_chain(i + 1)
        tip = pose_in(tree, chain.tip, 'odom').position
        base = pose_in(tree, chain.links[0], 'odom').position
        np.testing.assert_allclose(tip, world_T_a.apply(ik.ring_b_anchors_in_a[i]), atol=1e-9)
        np.testing.assert_allclose(base, world_T_a.apply(geom.ring_a_anchors[i]), atol=1e-9)
        upper = pose_in(tree, chain.links[2], 'ring_a')  # at the S-joint, z along the leg
        np.testing.assert_allclose(upper.rotation[:, 2], ik.unit_vectors[i], atol=1e-12)
    np.testing.assert_allclose(pose_in(tree, 'ring_b', 'odom').position, world_T_a.compose(a_T_b).position)

    markers = robot_markers(geom, a_T_b, grippers={'ring_a': True, 'ring_b': False},
                            target=a_T_b, world_T_a=world_T_a)
    by_key = {(m.ns, m.id): m for m in markers}
    assert {m.frame for m in markers} == {'ring_a', 'odom'}
    legs = by_key[('legs', 0)]
    figure = robot_figure(geom, a_T_b=a_T_b, world_T_a=Pose())
    np.testing.assert_allclose(legs.points, figure.leg_points.reshape(-1, 3), atol=1e-12)
    np.testing.assert_allclose(legs.colours[::2, :3] * 255.0, figure.leg_colours, atol=1e-9)
    assert by_key[('grippers', 0)].colour != by_key[('grippers', 1)].colour
    assert ('ghost', 0) in by_key and ('odom/legs', 0) in by_key
    np.testing.assert_allclose(by_key[('odom/legs', 0)].points,
                               world_T_a.apply(figure.leg_points.reshape(-1, 3)), atol=1e-12)
