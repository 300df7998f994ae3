"""Recording taps: the bundle format, the recorder's routing of bundles and subscriptions, and
over ROS, that a recorder takes every tapped message exactly once, whatever publishes with it.

Recordings are read back with the mcap reader and mcap-ros2 decoder, never with rrps' code."""

from __future__ import annotations

import os
import secrets
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_interfaces.status import source_node
from rrps_recording.transport.taps import OFFSET_WINDOW, TRANSITION_NS, TapRouter
from rrps_runtime.recording_bundle import MAGIC, BundleWriter, decode_bundle
from rrps_testing.ros_harness import Probe, Spinner, wait_for

NODE = '/rrps/driver_node'
STATE = '/rrps/actuators/state'
GRIPPERS = '/rrps/grippers/state'
JOINT_STATE = 'sensor_msgs/msg/JointState'


def _bundle(node, sent_ns, topics, frames):
    writer = BundleWriter(node)
    for name, kind in topics:
        writer.declare(name, kind)
    for index, publish_ns, data in frames:
        writer.add(index, publish_ns, data)
    return writer.take(sent_ns)


# --- the bundle format -----------------------------------------------------------------------

names = st.text(st.characters(codec='utf-8', exclude_categories=['Cs']), min_size=1, max_size=40)


@settings(max_examples=150, deadline=None)
@given(node=names, sent=st.integers(-2**63, 2**63 - 1),
       topics=st.lists(st.tuples(names, names), min_size=1, max_size=5),
       data=st.data())
def test_a_bundle_decodes_to_what_was_added(node, sent, topics, data):
    frames = data.draw(st.lists(st.tuples(st.integers(0, len(topics) - 1),
                                          st.integers(-2**63, 2**63 - 1),
                                          st.binary(max_size=300)), max_size=30))
    bundle = decode_bundle(_bundle(node, sent, topics, frames))
    assert bundle.node == node and bundle.sent_ns == sent
    assert bundle.topics == tuple(topics)
    assert bundle.frames == tuple(frames)


def test_a_bundle_is_the_cdr_of_a_uint8_multi_array():
    """Any ROS tool can take it: rclpy's own serialisation gives the same bytes."""
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import UInt8MultiArray

    for size in range(0, 9):  # every alignment of the data's end
        cdr = _bundle(NODE, 7, [(STATE, JOINT_STATE)], [(0, 5, b'x' * size)])
        msg = deserialize_message(cdr, UInt8MultiArray)
        assert bytes(msg.data).startswith(MAGIC)
        assert serialize_message(msg) == cdr
        assert decode_bundle(serialize_message(msg)).frames == ((0, 5, b'x' * size),)


def test_a_malformed_bundle_is_refused_with_a_reason():
    good = _bundle(NODE, 7, [(STATE, JOINT_STATE), (GRIPPERS, JOINT_STATE)],
                   [(0, 5, b'abc'), (1, 6, b'defg')])
    decode_bundle(good)
    for cut in range(len(good)):  # cut anywhere: refused, never a crash or a wrong bundle
        with pytest.raises(ValueError):
            decode_bundle(good[:cut])
    with pytest.raises(ValueError, match='not a recording bundle'):
        decode_bundle(good[:16] + b'X' + good[17:])
    with pytest.raises(ValueError, match='little-endian'):
        decode_bundle(b'\x00\x00' + good[2:])
    bad_index = _bundle(NODE, 7, [(STATE, JOINT_STATE)], [(3, 5, b'abc')])
    with pytest.raises(ValueError, match='past the table'):
        decode_bundle(bad_index)


# --- the router ------------------------------------------------------------------------------

def test_a_topic_is_tapped_only_when_every_publisher_taps_it():
    router = TapRouter()
    router.receive(decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)], [])), 0)
    assert router.covers(STATE, [NODE])
    assert not router.covers(STATE, [NODE, '/rrps/tool'])  # an operator's tool publishes too
    assert not router.covers(STATE, [])
    assert not router.covers(GRIPPERS, [NODE])  # the node does not tap that one
    router.forget([])
    assert not router.covers(STATE, [NODE])  # the node's tap is gone


def test_log_times_are_publish_times_plus_the_smallest_bundle_delay():
    router = TapRouter()
    router.set_tapped(STATE, True, 0)
    offset = 3_000_000_000  # the publisher's clock is 3 s behind the recorder's
    delays = [900_000, 400_000, 2_000_000, 700_000]
    for k, delay in enumerate(delays):
        sent = 10**12 + k * 10**8
        _, out = router.receive(decode_bundle(_bundle(
            NODE, sent, [(STATE, JOINT_STATE)], [(0, sent - 50_000_000, b'm%d' % k)])),
            sent + offset + delay)
        assert out == [(STATE, sent - 50_000_000 + offset + min(delays[:k + 1]), b'm%d' % k)]
    assert OFFSET_WINDOW >= len(delays)


def test_frames_of_a_subscribed_topic_are_ignored_and_a_tapped_topic_ignores_its_subscription():
    router = TapRouter()
    bundle = decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)], [(0, 0, b'a')]))
    changed, out = router.receive(bundle, 0)
    assert changed and out == []  # not tapped (yet): the subscription records it
    assert router.subscribed(STATE, b'a', 1)
    router.set_tapped(STATE, True, 10)
    later = 10 + TRANSITION_NS
    assert not router.subscribed(STATE, b'late', later)
    changed, out = router.receive(decode_bundle(
        _bundle(NODE, 0, [(STATE, JOINT_STATE)], [(0, 0, b'b')])), later)
    assert not changed and [d for _, _, d in out] == [b'b']


@settings(max_examples=200, deadline=None)
@given(n=st.integers(10, 80), data=st.data())
def test_a_switch_between_subscription_and_taps_records_every_message_once(n, data):
    """Messages 0..n-1 are published 2 ms apart. The subscription delivers them up to some
    point after the switch (in flight when it is destroyed); bundles of 5 carry them from some
    point before. Whatever those points, each message is recorded exactly once."""
    switch = data.draw(st.integers(1, n - 1), label='switch')
    delivered = data.draw(st.integers(switch, n), label='subscription delivers up to')
    first_bundled = data.draw(st.integers(0, delivered), label='bundles from')
    router = TapRouter()
    # the tap's first (empty) bundle arrives before anything: its table is known
    router.receive(decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)], [])), 0)
    recorded = []
    t = lambda i: 1_000_000 + 2_000_000 * i  # noqa: E731
    for i in range(delivered):
        if i == switch:
            router.set_tapped(STATE, True, t(i))
        if router.subscribed(STATE, b'm%03d' % i, t(i)):
            recorded.append(i)
    if delivered <= switch:
        router.set_tapped(STATE, True, t(switch))
    for start in range(first_bundled, n, 5):
        frames = [(0, t(i), b'm%03d' % i) for i in range(start, min(n, start + 5))]
        _, out = router.receive(decode_bundle(_bundle(NODE, t(start + 5), [(STATE, JOINT_STATE)],
                                                      frames)), max(t(start + 5), t(switch)))
        recorded += [int(d[1:]) for _, _, d in out]
    assert sorted(recorded) == list(range(n))


def test_a_topic_that_stops_being_tapped_loses_and_doubles_nothing():
    router = TapRouter()
    router.receive(decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)], [])), 0)
    router.set_tapped(STATE, True, 0)
    recorded = []
    _, out = router.receive(decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)],
                                                  [(0, 1, b'a'), (0, 2, b'b')])), 5)
    recorded += [d for _, _, d in out]
    router.set_tapped(STATE, False, 10)  # another publisher appeared: subscribed from now on
    for message in (b'b', b'c', b'tool'):  # the subscription's first messages: one was tapped
        if router.subscribed(STATE, message, 11):
            recorded.append(message)
    _, out = router.receive(decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)],
                                                  [(0, 3, b'c'), (0, 4, b'd')])), 12)
    recorded += [d for _, _, d in out]
    assert sorted(recorded) == [b'a', b'b', b'c', b'd', b'tool']
    # after the transition the bundles' copies are ignored
    _, out = router.receive(decode_bundle(_bundle(NODE, 0, [(STATE, JOINT_STATE)],
                                                  [(0, 5, b'e')])), 12 + TRANSITION_NS)
    assert out == []
    assert router.subscribed(STATE, b'e', 12 + TRANSITION_NS)


# --- over ROS: a tapped node and the recorder --------------------------------------------------

# A namespace of this run only: other ROS processes on the machine may share the domain id.
NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'


class _TappedTalker:
    """A node publishing JointStates through a recording tap, as the stack's nodes do."""

    def __init__(self, context):
        from rclpy.node import Node
        from sensor_msgs.msg import JointState

        from rrps_runtime.qos import STATE_QOS
        from rrps_runtime.recording_tap import RecordingTap
        self.node = Node('tapped_talker', context=context, namespace=NS)
        self.tap = RecordingTap(self.node)
        self.publisher = self.tap.create_publisher(JointState, 'actuators/state', STATE_QOS)
        self.sent = []

    def publish(self, value: float):
        from rrps_runtime.messages import joint_state_msg
        msg = joint_state_msg(self.node.get_clock().now().to_msg(), [value] * 6)
        self.publisher.publish(msg)
        self.sent.append(value)


def _recorded_positions(path, topic):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(path, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [d.position[0] for _, _, _, d in reader.iter_decoded_messages(topics=[topic])]


@pytest.mark.ros
def test_a_tap_is_idle_without_a_recorder(ros_context):
    from sensor_msgs.msg import JointState

    talker = _TappedTalker(ros_context)
    probe = Probe(context=ros_context, namespace=NS)
    got = probe.collect(JointState, 'actuators/state')
    with Spinner(ros_context, [talker.node, probe]):
        assert wait_for(lambda: talker.publisher.publisher.get_subscription_count() > 0, 10.0)
        for i in range(50):
            talker.publish(float(i))
            time.sleep(0.002)
        assert wait_for(lambda: len(got) == 50, 10.0)
        time.sleep(0.3)  # three flush periods
    assert not talker.tap.active and talker.tap.bundles_sent == 0
    assert [m.position[0] for m in got] == [float(i) for i in range(50)]


@pytest.mark.ros
def test_the_recorder_takes_a_tapped_topic_from_the_tap_and_another_publisher_from_dds(
        ros_context, tmp_path):
    """Every message once: tapped while the node alone publishes, subscribed while a tool
    publishes too, tapped again when the tool is gone."""
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState

    from rrps_recording.nodes.recorder_node import RecorderNode
    from rrps_runtime.messages import joint_state_msg
    topic = f'{NS}/actuators/state'
    talker = _TappedTalker(ros_context)
    recorder = RecorderNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('prefix', value='taps'),
        Parameter('discovery_period', value=0.1), Parameter('flush_period', value=0.2),
        Parameter('flight_recorder', value=False), Parameter('tf_rate', value=0.0)])
    tool = Probe(context=ros_context, name='operator_tool', namespace=NS)
    tool_sent = []

    def stream(count, start, *, with_tool=None):
        for i in range(count):
            talker.publish(start + i)
            if with_tool is not None and i % 4 == 0:
                value = 1000.0 + start + i
                with_tool.publish(joint_state_msg(tool.get_clock().now().to_msg(), [value] * 6))
                tool_sent.append(value)
            time.sleep(0.004)

    with Spinner(ros_context, [talker.node, recorder, tool]):
        assert wait_for(lambda: recorder._taps.is_tapped(topic))
        assert topic not in recorder._raw_subscriptions and talker.tap.active
        stream(100, 0.0)
        tool_pub = tool.publisher(JointState, 'actuators/state')
        assert wait_for(lambda: topic in recorder._raw_subscriptions)
        assert not recorder._taps.is_tapped(topic)
        assert wait_for(lambda: recorder._raw_subscriptions[topic].get_publisher_count() == 2, 10.0)
        stream(100, 100.0, with_tool=tool_pub)
        tool.destroy_publisher(tool_pub)
        assert wait_for(lambda: recorder._taps.is_tapped(topic))
        assert topic not in recorder._raw_subscriptions
        stream(100, 200.0)
        time.sleep(0.5)  # the talker's last bundle
    recorder.destroy_node()
    recorded = _recorded_positions(tmp_path / 'taps' / 'taps_0.mcap', topic)
    assert sorted(v for v in recorded if v < 1000.0) == talker.sent  # each once, none lost
    assert sorted(v for v in recorded if v >= 1000.0) == tool_sent
    assert talker.tap.bundles_sent > 0


@pytest.mark.ros
def test_a_recorder_takes_no_tap_of_another_namespace(ros_context, tmp_path):
    """Another robot's nodes (a fleet on one network) keep their bundles: subscribing to them
    would bring that robot's streams across the network to this one."""
    from rclpy.parameter import Parameter

    from rrps_recording.nodes.recorder_node import RecorderNode
    talker = _TappedTalker(ros_context)  # in NS
    recorder = RecorderNode(context=ros_context, namespace='/robot_2', parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('prefix', value='other'),
        Parameter('discovery_period', value=0.1), Parameter('record', value=False),
        Parameter('flight_recorder', value=False), Parameter('tf_rate', value=0.0)])
    with Spinner(ros_context, [talker.node, recorder]):
        assert wait_for(lambda: f'{NS}/tapped_talker/recording_tap' in dict(recorder.get_topic_names_and_types()),
                        10.0)
        time.sleep(0.5)  # five discovery periods
        for i in range(20):
            talker.publish(float(i))
            time.sleep(0.003)
        time.sleep(0.3)
    recorder.destroy_node()
    assert not recorder._bundle_subscriptions and not talker.tap.active


@pytest.mark.ros
def test_without_taps_the_recorder_subscribes_to_every_topic(ros_context, tmp_path):
    from rclpy.parameter import Parameter

    from rrps_recording.nodes.recorder_node import RecorderNode
    topic = f'{NS}/actuators/state'
    talker = _TappedTalker(ros_context)
    recorder = RecorderNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('prefix', value='dds'),
        Parameter('discovery_period', value=0.1), Parameter('use_taps', value=False),
        Parameter('flight_recorder', value=False), Parameter('tf_rate', value=0.0)])
    with Spinner(ros_context, [talker.node, recorder]):
        assert wait_for(lambda: topic in recorder._raw_subscriptions)
        assert wait_for(lambda: recorder._raw_subscriptions[topic].get_publisher_count() == 1, 10.0)
        for i in range(100):
            talker.publish(float(i))
            time.sleep(0.003)
        time.sleep(0.5)
    recorder.destroy_node()
    assert not talker.tap.active  # nobody took the bundles
    assert _recorded_positions(tmp_path / 'dds' / 'dds_0.mcap', topic) == talker.sent


@pytest.mark.ros
def test_an_operator_save_holds_every_tapped_message_published_before_it(ros_context, tmp_path):
    from rclpy.parameter import Parameter
    from std_srvs.srv import Trigger

    from rrps_recording.nodes.recorder_node import RecorderNode
    topic = f'{NS}/actuators/state'
    talker = _TappedTalker(ros_context)
    recorder = RecorderNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('record', value=False),
        Parameter('discovery_period', value=0.1), Parameter('tf_rate', value=0.0)])
    with Spinner(ros_context, [talker.node, recorder]):
        assert wait_for(lambda: recorder._taps.is_tapped(topic) and talker.tap.active, 15.0)
        for i in range(60):
            talker.publish(float(i))
            time.sleep(0.002)
        # at once after the last one: it is still in the talker's tap, not yet sent
        response = recorder._on_save(Trigger.Request(), Trigger.Response())
        assert response.success
        recorder.wait_for_dumps(timeout=10.0)
    recorder.destroy_node()
    assert _recorded_positions(response.message, topic) == talker.sent


@pytest.mark.ros
def test_a_malformed_bundle_is_counted_and_reported_and_recording_goes_on(ros_context, tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.parameter import Parameter
    from std_msgs.msg import UInt8MultiArray

    from rrps_interfaces.recording import RecorderStatus
    from rrps_recording.nodes.recorder_node import RecorderNode
    from rrps_runtime.recording_tap import TAP_QOS
    topic = f'{NS}/actuators/state'
    talker = _TappedTalker(ros_context)
    forger = Probe(context=ros_context, name='forger', namespace=NS)
    garbage = forger.create_publisher(UInt8MultiArray, 'forger/recording_tap', TAP_QOS)
    diagnostics = forger.collect(DiagnosticArray, '/diagnostics')
    recorder = RecorderNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('output_dir', value=str(tmp_path)), Parameter('prefix', value='bad'),
        Parameter('discovery_period', value=0.1), Parameter('flight_recorder', value=False),
        Parameter('tf_rate', value=0.0)])
    with Spinner(ros_context, [talker.node, recorder, forger]):
        assert wait_for(lambda: recorder._taps.is_tapped(topic) and talker.tap.active
                        and garbage.get_subscription_count() > 0, 15.0)
        for i in range(40):
            talker.publish(float(i))
            if i % 10 == 0:
                garbage.publish(UInt8MultiArray(data=list(b'RRPSTAP1 not a bundle')))
            time.sleep(0.003)
        assert wait_for(lambda: recorder.bad_bundles == 4, 10.0)

        def reported():
            for array in list(diagnostics):
                for status in array.status:
                    if source_node(status.name) == 'recorder_node':
                        values = RecorderStatus.from_values(
                            {kv.key: kv.value for kv in status.values})
                        if values.bad_bundles == 4:
                            return status
            return None
        assert wait_for(reported, 10.0)
        assert reported().level == b'\x01'  # WARN
        time.sleep(0.3)
    recorder.destroy_node()
    assert _recorded_positions(tmp_path / 'bad' / 'bad_0.mcap', topic) == talker.sent


@pytest.mark.ros
def test_a_tap_bundles_encoded_and_serialised_types_in_publish_order(ros_context):
    """JointState (kept and encoded per bundle by rrps_runtime.cdr) and Bool (no encoder:
    serialised by rclpy at publish time) from one node: the bundles hold every message once,
    in publish order, and each decodes to what was published."""
    from rclpy.node import Node
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool, UInt8MultiArray

    from rrps_interfaces.recording import RECORDING_TAP
    from rrps_runtime.messages import joint_state_msg
    from rrps_runtime.qos import STATE_QOS
    from rrps_runtime.recording_tap import TAP_QOS, RecordingTap
    node = Node('two_types', context=ros_context, namespace=NS)
    tap = RecordingTap(node)
    state_pub = tap.create_publisher(JointState, 'actuators/state', STATE_QOS)
    flag_pub = tap.create_publisher(Bool, 'teleop/enable', STATE_QOS)
    sink = Probe(context=ros_context, name='sink', namespace=NS)
    bundles = []
    sink.create_subscription(UInt8MultiArray, f'two_types/{RECORDING_TAP}', bundles.append,
                             TAP_QOS, raw=True)
    flags = sink.collect(Bool, 'teleop/enable')
    states = sink.collect(JointState, 'actuators/state')
    sent = []
    with Spinner(ros_context, [node, sink]):
        assert wait_for(lambda: tap.active)
        for i in range(120):
            if i % 3 == 0:
                msg, publisher = Bool(data=i % 2 == 0), flag_pub
            else:
                msg = joint_state_msg(node.get_clock().now().to_msg(), [float(i)] * 6)
                publisher = state_pub
            publisher.publish(msg)
            sent.append(msg)
            time.sleep(0.002)
        time.sleep(0.3)  # the last bundle
    decoded = [decode_bundle(data) for data in bundles]
    table = decoded[0].topics
    frames = [frame for bundle in decoded for frame in bundle.frames]
    types = {f'{NS}/actuators/state': JointState, f'{NS}/teleop/enable': Bool}
    recorded = [deserialize_message(cdr, types[table[index][0]]) for index, _, cdr in frames]
    assert recorded == sent
    for got, kind in ((flags, Bool), (states, JointState)):  # the topics' subscribers too
        expected = iter(m for m in sent if isinstance(m, kind))
        assert got and all(m in expected for m in got)  # in order (none lost on an idle machine)
    times = [t for _, t, _ in frames]
    assert times == sorted(times)
    node.destroy_node()


@pytest.mark.ros
def test_a_message_the_tap_cannot_encode_is_left_out_and_counted_never_raised(ros_context):
    from rclpy.node import Node
    from std_msgs.msg import UInt8MultiArray

    from rrps_interfaces.recording import RECORDING_TAP
    from rrps_runtime.recording_tap import TAP_QOS

    def unencodable(msg):
        raise ValueError('not encodable')

    talker = _TappedTalker(ros_context)
    talker.publisher._encode = unencodable
    sink = Node('sink', context=ros_context, namespace=NS)
    bundles = []
    sink.create_subscription(UInt8MultiArray, f'tapped_talker/{RECORDING_TAP}', bundles.append,
                             TAP_QOS, raw=True)
    with Spinner(ros_context, [talker.node, sink]):
        assert wait_for(lambda: talker.tap.active)
        for i in range(20):
            talker.publish(float(i))
        assert wait_for(lambda: talker.tap.unencodable == 20)
        assert wait_for(lambda: bundles)  # the tap goes on
    assert all(not decode_bundle(data).frames for data in bundles)
    sink.destroy_node()
