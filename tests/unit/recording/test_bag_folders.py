"""Bag folders as rosbag2 (Jazzy) writes them, checked against rosbag2's own files and read back
with the independent ``rosbags`` library (its ``rosbag2.Reader`` opens a Jazzy bag folder and
checks its metadata; its typestore decodes the CDR without rclpy or mcap-ros2).

The references in ``data/`` come from rosbag2's repository, branch ``jazzy``:

* ``rosbag2_v8_metadata.yaml`` is ``rosbag2_tests/resources/mcap/bag_with_topics_and_service_events/
  metadata.yaml`` verbatim: a metadata.yaml written by rosbag2 itself (version 8, yaml-cpp's
  emitter).
* ``rosbag2_jazzy_metadata.yaml`` is that file as rosbag2 for Jazzy writes it (bag metadata
  version 9, ``rosbag2_storage/include/rosbag2_storage/bag_metadata.hpp``): ``version: 9``,
  each ``offered_qos_profiles`` string turned into the nested sequence with the policies' names
  that ``YAML::convert<rclcpp::QoS>::encode`` writes from version 9 on
  (``rosbag2_storage/src/rosbag2_storage/qos.cpp``, ``rmw_qos_*_policy_to_str``; history 3 is
  ``unknown``), and ``ros_distro: jazzy`` (what ``SequentialWriter::init_metadata`` takes from
  ``ROS_DISTRO`` on a Jazzy install). Nothing else changed.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from rrps_recording.storage.bag import BagRecording, bag_files, is_bag, write_bag
from rrps_recording.storage.bag_metadata import METADATA_FILE, TopicInfo, metadata_file_text, yaml_text
from rrps_recording.storage.qos import QosSpec
from rrps_recording.transport.replay import RecordingSet

DATA = Path(__file__).parent / 'data'
BEST_EFFORT = QosSpec(depth=1, reliability=2)


def _structure(value):
    """Keys (in order) and value kinds of a YAML tree, lists reduced to their first item."""
    if isinstance(value, dict):
        return [(k, _structure(v)) for k, v in value.items()]
    if isinstance(value, list):
        return ['list', _structure(value[0])] if value else ['list']
    return type(value).__name__ if value is not None else 'null'


def _stack_messages():
    """(topic, type, QoS offered, rclpy messages) of four stack topics, with changing values."""
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool

    poses, states, flags = [], [], []
    for i in range(40):
        pose = PoseStamped()
        pose.header.frame_id = 'ring_a'
        pose.header.stamp.sec, pose.header.stamp.nanosec = 100, 1000 * i
        pose.pose.position.z = 0.4 + 1e-4 * i
        pose.pose.orientation.z, pose.pose.orientation.w = math.sin(0.01 * i), math.cos(0.01 * i)
        poses.append(pose)
        states.append(JointState(name=[f'leg_{k}' for k in range(1, 7)],
                                 position=[0.4 + 0.01 * k + 1e-4 * i for k in range(6)],
                                 effort=[float(i * k) for k in range(6)]))
        if i % 4 == 0:
            flags.append(Bool(data=i % 8 == 0))
    return [('/rrps/pose', 'geometry_msgs/msg/PoseStamped', (QosSpec(),), poses),
            ('/rrps/actuators/state', 'sensor_msgs/msg/JointState', (QosSpec(),), states),
            ('/rrps/teleop/enable', 'std_msgs/msg/Bool', (BEST_EFFORT, BEST_EFFORT), flags)]


def _cdr(message) -> bytes:
    """The CDR bytes the stack records: the recording taps' encoder for JointState (rclpy's
    ``serialize_message`` leaves 8 bytes past a JointState's end, which rosbags' size check
    refuses), rclpy's for the others."""
    from rclpy.serialization import serialize_message

    from rrps_runtime.cdr import joint_state_cdr
    return joint_state_cdr(message) if type(message).__name__ == 'JointState' else serialize_message(message)


def _write_bag(folder: Path, *, max_seconds: float = 0.0, close: bool = True):
    """A bag of the stack topics, 10 ms between messages of a topic, from t0; returns (bag, t0,
    the messages by topic)."""
    t0 = 1_700_000_000_000_000_000
    bag = BagRecording(folder, max_seconds=max_seconds, flush_period=0.05)
    sent = {}
    for topic, type_name, qos, messages in _stack_messages():
        bag.add_topic(TopicInfo(topic, type_name, qos))
        sent[topic] = messages
    batch = sorted(((topic, t0 + 10_000_000 * i + k, _cdr(m))
                    for k, (topic, messages) in enumerate(sent.items()) for i, m in enumerate(messages)),
                   key=lambda m: m[1])
    for message in batch:
        bag.write(*message)
    if close:
        bag.close()
    return bag, t0, sent


def test_metadata_text_is_what_rosbag2s_yaml_cpp_writes_byte_for_byte():
    """The emitter reproduces a metadata.yaml rosbag2 wrote (quoting, indents, '~', no final
    newline) and the Jazzy reference (nested QoS sequences)."""
    for name in ('rosbag2_v8_metadata.yaml', 'rosbag2_jazzy_metadata.yaml'):
        text = (DATA / name).read_text()
        assert yaml_text(yaml.safe_load(text)) == text, name
    reference = yaml.safe_load((DATA / 'rosbag2_jazzy_metadata.yaml').read_text())
    assert metadata_file_text(reference['rosbag2_bagfile_information']) == \
        (DATA / 'rosbag2_jazzy_metadata.yaml').read_text()


def test_a_bag_folder_has_rosbag2_jazzys_metadata_keys_and_values(tmp_path):
    bag, t0, sent = _write_bag(tmp_path / 'session', max_seconds=0.15)
    reference = yaml.safe_load((DATA / 'rosbag2_jazzy_metadata.yaml').read_text())
    text = (tmp_path / 'session' / METADATA_FILE).read_text()
    ours = yaml.safe_load(text)
    # the same keys, in the same order, with values of the same kinds, at every level
    assert _structure(ours) == _structure(reference)
    meta = ours['rosbag2_bagfile_information']
    assert (meta['version'], meta['storage_identifier'], meta['ros_distro']) == (9, 'mcap', 'jazzy')
    assert [p.name for p in bag.files] == ['session_0.mcap', 'session_1.mcap', 'session_2.mcap']
    assert meta['relative_file_paths'] == [p.name for p in bag.files]
    assert [f['path'] for f in meta['files']] == meta['relative_file_paths']
    total = sum(len(m) for m in sent.values())
    assert meta['message_count'] == total == sum(f['message_count'] for f in meta['files'])
    assert meta['starting_time']['nanoseconds_since_epoch'] == t0
    last = t0 + 10_000_000 * 39 + 1  # actuators/state's last message
    assert meta['duration']['nanoseconds'] == last - t0
    assert meta['files'][0]['starting_time']['nanoseconds_since_epoch'] == t0
    counts = {t['topic_metadata']['name']: t['message_count'] for t in meta['topics_with_message_count']}
    assert counts == {topic: len(m) for topic, m in sent.items()}
    enable = next(t['topic_metadata'] for t in meta['topics_with_message_count']
                  if t['topic_metadata']['name'] == '/rrps/teleop/enable')
    assert [q['reliability'] for q in enable['offered_qos_profiles']] == ['best_effort'] * 2
    assert enable['type_description_hash'].startswith('RIHS01_')
    assert meta['custom_data'] is None and meta['compression_format'] == ''


def test_rosbags_reads_the_bag_topics_types_counts_time_range_qos_and_values(tmp_path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    _, t0, sent = _write_bag(tmp_path / 'session', max_seconds=0.15)
    types = {topic: type_name for topic, type_name, _, _ in _stack_messages()}
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(tmp_path / 'session') as reader:
        assert reader.ros_distro == 'jazzy'
        assert {c.topic: c.msgtype for c in reader.connections} == types
        assert {c.topic: c.msgcount for c in reader.connections} == {t: len(m) for t, m in sent.items()}
        assert reader.message_count == sum(len(m) for m in sent.values())
        assert reader.start_time == t0 and reader.end_time == t0 + 10_000_000 * 39 + 1 + 1
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        assert [q.reliability.name for q in qos['/rrps/teleop/enable']] == ['BEST_EFFORT'] * 2
        assert [(q.reliability.name, q.durability.name, q.depth) for q in qos['/rrps/pose']] == \
            [('RELIABLE', 'VOLATILE', 10)]
        got = {topic: [] for topic in sent}
        for connection, timestamp, data in reader.messages():
            got[connection.topic].append((timestamp, store.deserialize_cdr(data, connection.msgtype)))
    for k, (topic, messages) in enumerate(sent.items()):
        assert [t for t, _ in got[topic]] == [t0 + 10_000_000 * i + k for i in range(len(messages))]
        for (_, value), message in zip(got[topic], messages):
            if topic == '/rrps/pose':
                assert (value.header.frame_id, value.header.stamp.nanosec, value.pose.position.z,
                        value.pose.orientation.z) == (message.header.frame_id, message.header.stamp.nanosec,
                                                      message.pose.position.z, message.pose.orientation.z)
            elif topic == '/rrps/actuators/state':
                assert list(value.name) == list(message.name)
                assert list(value.position) == list(message.position)
                assert list(value.effort) == list(message.effort)
            else:
                assert value.data == message.data


def test_a_bag_cut_by_a_crash_keeps_its_closed_files_readable_and_the_cut_one_replayable(tmp_path):
    """No close(): metadata.yaml lists the files closed at the splits (rosbags reads them); the
    file being written stays in the folder, unlisted, and a replay of the folder reads it too,
    up to its last flush."""
    from rosbags.rosbag2 import Reader

    bag, t0, sent = _write_bag(tmp_path / 'cut', max_seconds=0.15, close=False)
    meta = yaml.safe_load((tmp_path / 'cut' / METADATA_FILE).read_text())['rosbag2_bagfile_information']
    assert meta['relative_file_paths'] == ['cut_0.mcap', 'cut_1.mcap']
    with Reader(tmp_path / 'cut') as reader:
        assert reader.message_count == meta['message_count'] == sum(1 for _ in reader.messages())
    assert [p.name for p in bag_files(tmp_path / 'cut')] == ['cut_0.mcap', 'cut_1.mcap', 'cut_2.mcap']
    replay = RecordingSet([tmp_path / 'cut'])
    total = sum(len(m) for m in sent.values())
    replayed = list(replay.messages())
    # the cut file loses at most what came after its last flush (0.05 s of 10 ms messages)
    assert total - 3 * 6 <= len(replayed) < total + 1
    assert replay.start_ns == t0
    bag.close()
    assert [p.name for p in bag_files(tmp_path / 'cut')] == ['cut_0.mcap', 'cut_1.mcap', 'cut_2.mcap']
    assert len(list(RecordingSet([tmp_path / 'cut']).messages())) == total


def test_a_new_bag_is_an_empty_bag_and_an_existing_folder_is_refused(tmp_path):
    from rosbags.rosbag2 import Reader

    bag = BagRecording(tmp_path / 'empty')
    meta = yaml.safe_load((tmp_path / 'empty' / METADATA_FILE).read_text())['rosbag2_bagfile_information']
    assert meta['message_count'] == 0 and meta['relative_file_paths'] == []
    assert meta['starting_time']['nanoseconds_since_epoch'] == 2**63 - 1  # rosbag2's empty bag
    with Reader(tmp_path / 'empty') as reader:
        assert reader.message_count == 0
    with pytest.raises(FileExistsError, match='already exists'):
        BagRecording(tmp_path / 'empty')
    bag.close()
    assert is_bag(tmp_path / 'empty') and not is_bag(tmp_path)


def test_write_bag_writes_a_whole_folder_named_like_rosbag2s(tmp_path):
    from rosbags.rosbag2 import Reader

    path = write_bag(tmp_path / 'flight_x', [TopicInfo('/x', 'std_msgs/msg/Bool')],
                     [('/x', 3, b'\x00\x01\x00\x00\x01'), ('/x', 1, b'\x00\x01\x00\x00\x00')])
    assert path == tmp_path / 'flight_x' / 'flight_x_0.mcap' and path.is_file()
    assert not list(tmp_path.glob('*.part'))
    with Reader(tmp_path / 'flight_x') as reader:
        assert [t for _, t, _ in reader.messages()] == [1, 3]
    with pytest.raises(FileExistsError):
        write_bag(tmp_path / 'flight_x', [], [])
    with pytest.raises(ValueError, match='not a bag folder'):
        bag_files(tmp_path / 'nothing_here')


def test_free_name_never_returns_a_folder_that_exists_or_is_being_written(tmp_path):
    from rrps_recording.storage.bag import free_name

    assert free_name(tmp_path, 'rrps_x') == 'rrps_x'
    (tmp_path / 'rrps_x').mkdir()
    (tmp_path / 'rrps_x_1.part').mkdir()
    assert free_name(tmp_path, 'rrps_x') == 'rrps_x_2'
    assert free_name(tmp_path, 'rrps_x', taken={'rrps_x_2'}) == 'rrps_x_3'
