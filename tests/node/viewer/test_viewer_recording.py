"""The viewer's recording side over ROS: "Save last 60 s" writes the flight recorder and offers
the file to the operator's browser; the replay timeline follows replay/status and drives the
replay node's seek, pause and rate."""

from __future__ import annotations

import os
import secrets
import time

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rrps_testing.processes import free_port
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

# A namespace of this run only: other ROS processes on the machine may share the domain id.
NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'
TOKEN = 'recording-test-token'


@pytest.fixture
def viewer(ros_context):
    from rclpy.parameter import Parameter

    from rrps_viewer.nodes.viewer_node import ViewerNode
    node = ViewerNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('port', value=free_port()), Parameter('token', value=TOKEN)])
    node.told = []
    node.sent = []
    node.viewer.tell = lambda cid, message, ok: node.told.append((cid, message, ok))
    node.recording._send_file = lambda cid, name, content: node.sent.append((cid, name, content)) or True
    return node


def _operator(control, client_id: int = 7) -> int:
    control.connect(client_id)
    assert control.authenticate(client_id, TOKEN).ok
    assert control.take_control(client_id).ok
    return client_id


def test_save_last_60_s_writes_the_flight_recorder_and_offers_the_file(ros_context, viewer,
                                                                      tmp_path):
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter

    from rrps_recording.nodes.recorder_node import RecorderNode
    from rrps_runtime.messages import pose_to_msg
    recorder = RecorderNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('record', value=False),
        Parameter('discovery_period', value=0.1)])
    probe = Probe(context=ros_context, namespace=NS)
    pub = probe.publisher(PoseStamped, 'pose')
    with Spinner(ros_context, [viewer, recorder, probe]):
        assert wait_for(lambda: f'{NS}/pose' in recorder._raw_subscriptions)
        for i in range(50):
            pub.publish(pose_to_msg([0, 0, 0.42 + 1e-4 * i], [0, 0, 0, 1], frame_id='ring_a',
                                    stamp=probe.get_clock().now().to_msg()))
            time.sleep(0.01)
        viewer.control.connect(3)  # a read-only browser is refused
        viewer.save_flight_recording(3)
        assert wait_for(lambda: any(c == 3 and not ok for c, _, ok in viewer.told))
        cid = _operator(viewer.control)
        assert wait_for(lambda: viewer.recording._save_client.service_is_ready())
        viewer.save_flight_recording(cid)
        assert wait_for(lambda: viewer.sent)
    [(to, name, content)] = viewer.sent
    # the dump is a bag folder flight_<time>_operator/ of one file, which the browser gets
    assert to == cid and name.startswith('flight_') and name.endswith('_operator_0.mcap')
    bag = tmp_path / name.removesuffix('_0.mcap')
    assert (bag / 'metadata.yaml').is_file()
    assert (bag / name).read_bytes() == content
    with open(bag / name, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        zs = [d.pose.position.z for _, c, _, d in reader.iter_decoded_messages()
              if c.topic == f'{NS}/pose']
    assert len(zs) == 50 and zs[-1] == pytest.approx(0.42 + 49e-4)
    assert any(c == cid and ok and 'download' in m for c, m, ok in viewer.told)


def test_the_timeline_follows_the_replay_and_drives_it(ros_context, viewer, tmp_path):
    from rclpy.parameter import Parameter
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Bool

    from rrps_recording.nodes.replay_node import ReplayNode
    from rrps_recording.storage.mcap_files import TopicInfo, write_recording
    path = write_recording(tmp_path / 'r.mcap', [TopicInfo(f'{NS}/flag', 'std_msgs/msg/Bool')],
                           [(f'{NS}/flag', i * 10**8, serialize_message(Bool(data=True)))
                            for i in range(21)])  # 2 s
    replay = ReplayNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('files', value=[str(path)]), Parameter('paused', value=True)])
    assert viewer.frame().replay is None  # no replay yet: no timeline
    with Spinner(ros_context, [viewer, replay]):
        assert wait_for(lambda: viewer.frame().replay is not None)
        status = viewer.frame().replay
        assert status.paused and status.duration == pytest.approx(2.0) and status.time == 0.0
        cid = _operator(viewer.control)
        assert wait_for(lambda: viewer.recording._replay_client.service_is_ready())
        viewer.replay_control(cid, seek=1.5)
        assert wait_for(lambda: viewer.frame().replay.time == pytest.approx(1.5))
        viewer.replay_control(cid, rate=4.0, paused=False)
        assert wait_for(lambda: viewer.frame().replay.finished)
        assert viewer.frame().replay.rate == 4.0
    assert replay.published == 6  # 1.5 s .. 2.0 s
    assert not [m for _, m, ok in viewer.told if not ok]
