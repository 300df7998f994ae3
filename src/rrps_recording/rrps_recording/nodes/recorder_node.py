"""recorder_node: every rrps topic and /diagnostics to a rosbag2 bag folder, and the flight recorder.

Recording (``record``): the selected topics, found in the ROS graph every ``discovery_period`` s, are written
as received (raw CDR, never deserialised) to the bag folder ``<output_dir>/<prefix>/``, which must not exist
(:mod:`rrps_recording.storage.bag`). A topic whose every publisher taps it is taken from the recording taps'
bundles instead of a subscription (``use_taps``, :class:`rrps_recording.transport.taps.TapRouter`). The robot's
``/tf`` is written at ``tf_rate`` Hz from the newest pose, odometry and grippers
(:class:`rrps_recording.robot_tf.RobotTf`); the live /tf and /tf_static are then not recorded. Flight recorder
(``flight_recorder``): the last ``buffer_seconds``, dumped after a fault and on ``flight_recorder/save``
(std_srvs/Trigger; the answer's message is the MCAP file's path), by
:class:`rrps_recording.transport.flight_recorder.FlightRecorder`. See docs/recording.md.

    recorder_node --ros-args -r __ns:=/rrps -p output_dir:=recordings
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from std_srvs.srv import Trigger

from rrps_description.geometry import load_robot
from rrps_interfaces.climb import CLIMB_STATUS
from rrps_interfaces.recording import (
    FLIGHT_RECORDER_SAVE,
    RECORDING_TAP,
    TF,
    TF_STATIC,
    RecorderStatus,
    RecorderTrigger,
)
from rrps_interfaces.status import DIAGNOSTICS
from rrps_interfaces.teleop import TELEOP_STATUS
from rrps_recording.robot_tf import TF_TOPIC, RobotTf
from rrps_recording.storage.bag import BagRecording, free_name
from rrps_recording.storage.bag_metadata import TopicInfo
from rrps_recording.storage.mcap_files import COMPRESSIONS
from rrps_recording.storage.schemas import message_class
from rrps_recording.topic_graph import recorded_topic, selected, subscription_for
from rrps_recording.transport.flight_recorder import FlightRecorder
from rrps_recording.transport.taps import TapRouter, fully_qualified_node
from rrps_recording.transport.triggers import FaultWatch, StatusEvent
from rrps_runtime.diagnostics import OBSERVER, OK, WARN, Diagnostics
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import SHUTDOWN_DEADLINE, run_nodes
from rrps_runtime.qos import STATE_QOS
from rrps_runtime.recording_bundle import BUNDLE_TYPE, decode_bundle
from rrps_runtime.recording_tap import FLUSH_PERIOD as TAP_FLUSH_PERIOD
from rrps_runtime.recording_tap import TAP_QOS

__all__ = ['RecorderNode', 'main']

#: recorder_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('recorder_node', 'rrps_recording', [
    ROBOT,
    Parameter('output_dir', 'rrps_recordings', 'folder of the recordings'),
    Parameter('prefix', '', 'bag folder name in output_dir, which must not exist (empty: rrps_<date>_<time>)'),
    Parameter('record', True, 'write every message to MCAP files'),
    Parameter('flight_recorder', True, 'keep the last buffer_seconds for fault dumps'),
    Parameter('buffer_seconds', 60.0, 'flight recorder window', unit='s', range=(1.0, 3600.0)),
    Parameter('buffer_max_mb', 512.0, 'flight recorder memory bound (of messages)', unit='MiB',
              range=(1.0, 65536.0)),
    Parameter('topics', ('',), "topics or prefixes to record ('' = the node's namespace, /diagnostics, /tf and "
              '/tf_static)'),
    Parameter('discovery_period', 1.0, 'graph discovery period', unit='s', range=(0.05, 60.0)),
    Parameter('max_file_size_mb', 0.0, 'start a new file past this size; 0 = no limit', unit='MiB',
              range=(0.0, 1e6)),
    Parameter('max_file_duration', 0.0, 'start a new file past this duration; 0 = no limit', unit='s',
              range=(0.0, 1e6)),
    Parameter('compression', 'zstd', 'chunk compression', choices=tuple(COMPRESSIONS)),
    Parameter('flush_period', 1.0, 'write the chunk in progress at least this often (what a crash can lose)',
              unit='s', range=(0.05, 600.0)),
    Parameter('depth', 100, 'subscription queue depth', range=(1, 100000)),
    Parameter('use_taps', True, "record the nodes' recording taps instead of subscribing to the topics they "
              'cover'),
    Parameter('tf_rate', 10.0, '/tf written at this rate; 0 = none', unit='Hz', range=(0.0, 1000.0)),
    Parameter('post_trigger', 2.0, 'a fault dump waits this long to include the aftermath', unit='s',
              range=(0.0, 600.0)),
    Parameter('min_dump_interval', 10.0, 'at most one fault dump this often', unit='s', range=(0.0, 3600.0)),
])


class RecorderNode(Node):
    """Records the rrps topics to MCAP and keeps the flight recorder; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('recorder_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        self.output_dir = Path(values['output_dir'])
        prefix = values['prefix']
        self.record = values['record']
        self.topics = list(values['topics'])
        self.discovery_period = values['discovery_period']
        self.depth = values['depth']
        self.use_taps = values['use_taps']
        tf_rate = values['tf_rate']
        self.prefix = prefix or free_name(self.output_dir, time.strftime('rrps_%Y%m%d_%H%M%S'))
        self._lock = threading.Lock()
        self._topics: dict[str, TopicInfo] = {}
        self._raw_subscriptions: dict[str, object] = {}
        self._bundle_subscriptions: dict[str, object] = {}
        self._taps = TapRouter()
        self._graph_signature: tuple = ()
        self.bad_bundles = 0
        self.dropped_topics: dict[str, str] = {}
        self._tf = RobotTf(self.geometry, self.get_namespace())
        ns = self.get_namespace().rstrip('/')
        try:
            self.recording = (BagRecording(self.output_dir / self.prefix,
                                           max_bytes=int(values['max_file_size_mb'] * 2**20),
                                           max_seconds=values['max_file_duration'],
                                           compression=values['compression'],
                                           flush_period=values['flush_period'])
                              if self.record else None)
        except FileExistsError as exc:
            raise ValueError(f'prefix: {exc}') from None
        self.flight = (FlightRecorder(self.output_dir, self.get_logger().error,
                                      buffer_seconds=values['buffer_seconds'],
                                      max_bytes=int(values['buffer_max_mb'] * 2**20),
                                      post_trigger=values['post_trigger'],
                                      min_dump_interval=values['min_dump_interval'])
                       if values['flight_recorder'] else None)
        self.messages = 0
        self._faults = FaultWatch()
        self._writes_tf = tf_rate > 0.0
        if self._writes_tf:
            self._add_topic(TF_TOPIC)
            self.create_timer(1.0 / tf_rate, self._write_tf)
        self._diag = Diagnostics(self, 'recorder', hardware_id=OBSERVER)
        # The fault triggers' topics (full name: event source, type): heard through their
        # recording subscription (_on_raw), or through one of their own when not recorded.
        self._triggers = {DIAGNOSTICS: (DIAGNOSTICS, DiagnosticArray),
                          f'{ns}/{TELEOP_STATUS}': (TELEOP_STATUS, DiagnosticStatus),
                          f'{ns}/{CLIMB_STATUS}': (CLIMB_STATUS, DiagnosticStatus)}
        for name, (_, msg_type) in self._triggers.items():
            if not self._selected(name):
                self.create_subscription(msg_type, name,
                                         lambda data, name=name: self._on_trigger(name, data),
                                         STATE_QOS, raw=True)
        self.create_service(Trigger, FLIGHT_RECORDER_SAVE, self._on_save)
        self.create_timer(self.discovery_period, self._discover)
        self.create_timer(0.1, self._housekeeping)
        self.create_timer(1.0, self._report)
        self._discover()
        where = f'recording to {self.recording.path}' if self.recording else 'not recording'
        self.get_logger().info(
            f'{where}; flight recorder '
            + (f'on ({self.flight.buffer_seconds:g} s)' if self.flight is not None else 'off'))

    # --- topics ------------------------------------------------------------------------------

    def _selected(self, name: str) -> bool:
        return selected(name, self.get_namespace(), self.topics, (DIAGNOSTICS, TF, TF_STATIC))

    def _add_topic(self, topic: TopicInfo) -> None:
        with self._lock:
            self._topics[topic.name] = topic
        if self.recording is not None:
            self.recording.add_topic(topic)

    def _discover(self, *, force: bool = False) -> None:
        """Find the selected topics and the recording taps; subscribe (raw) to every selected
        topic that has a publisher and that the taps do not cover."""
        now = time.time_ns()
        graph = self.get_topic_names_and_types()
        # The graph's shape (topics, types, publisher counts, nodes): while it is unchanged and
        # no tap's topics changed, nothing is looked at again (the per-topic endpoint queries are
        # most of discovery's cost).
        signature = (tuple((name, tuple(types)) for name, types in graph),
                     tuple(self.get_node_names_and_namespaces()),
                     tuple(self.count_publishers(name) for name, _ in graph))
        if signature == self._graph_signature and not force:
            return
        self._graph_signature = signature
        if self.use_taps:
            self._discover_taps(graph)
        for name, types in graph:
            if not self._selected(name) or self._is_tap(name, types):
                continue
            if name in (TF, TF_STATIC) and self._writes_tf:
                continue  # written by this node from the robot's state (/tf: every joint)
            if len(types) != 1:
                self.dropped_topics[name] = f'several types {types}'
                continue
            infos = self.get_publishers_info_by_topic(name)
            if not infos:
                continue  # subscribers only: nothing to record (yet)
            type_name = types[0]
            if name not in self._topics:
                try:
                    topic = recorded_topic(name, type_name, infos)
                except ValueError as exc:
                    self.dropped_topics[name] = str(exc)
                    continue
                self._add_topic(topic)
                self.dropped_topics.pop(name, None)
            tapped = self.use_taps and self._taps.covers(
                name, (fully_qualified_node(i.node_namespace, i.node_name) for i in infos))
            self._taps.set_tapped(name, tapped, now)
            subscription = self._raw_subscriptions.get(name)
            if tapped and subscription is not None:
                self.destroy_subscription(self._raw_subscriptions.pop(name))
            elif not tapped and subscription is None:
                topic = self._topics[name]
                self._raw_subscriptions[name] = self.create_subscription(
                    message_class(type_name), name,
                    lambda data, name=name: self._on_raw(name, data),
                    subscription_for(topic.offered_qos, self.depth),
                    raw=True)

    @staticmethod
    def _is_tap(name: str, types) -> bool:
        return name.endswith('/' + RECORDING_TAP) and list(types) == [BUNDLE_TYPE]

    def _discover_taps(self, graph) -> None:
        """Subscribe to the recording taps of the recorded namespaces (never another robot's:
        its streams would cross the network); forget the nodes whose tap is gone."""
        alive = set()
        for name, types in graph:
            if not self._is_tap(name, types) or not self._selected(name):
                continue
            infos = self.get_publishers_info_by_topic(name)
            alive.update(fully_qualified_node(i.node_namespace, i.node_name) for i in infos)
            if name not in self._bundle_subscriptions and infos:
                self._bundle_subscriptions[name] = self.create_subscription(
                    message_class(BUNDLE_TYPE), name, self._on_bundle, TAP_QOS, raw=True)
        self._taps.forget(alive)

    def _on_bundle(self, data: bytes) -> None:
        try:
            bundle = decode_bundle(data)
        except ValueError as exc:
            self.bad_bundles += 1
            self.get_logger().warning(f'malformed recording bundle ignored: {exc}',
                                      throttle_duration_sec=5.0)
            return
        changed, messages = self._taps.receive(bundle, time.time_ns())
        topics = self._topics
        if any(topic not in topics for topic, _, _ in messages):
            messages = [m for m in messages if m[0] in topics]
        self._store_many(messages)
        if changed:
            self._discover(force=True)  # a node's tapped topics are known: stop subscribing

    def _on_raw(self, topic: str, data: bytes) -> None:
        t = time.time_ns()
        if self._taps.subscribed(topic, data, t):
            self._store(topic, t, data)
        if topic in self._triggers:
            self._on_trigger(topic, data)

    def _store(self, topic: str, t: int, data: bytes) -> None:
        self._store_many(((topic, t, data),))

    def _store_many(self, messages) -> None:
        """Record messages (topic, log time [ns], CDR bytes) to the file and the ring; keep
        the newest of /tf's inputs."""
        self.messages += len(messages)
        tf_inputs, latest = self._tf.inputs, self._tf.latest
        for topic, _, data in messages:
            if topic in tf_inputs:
                latest[topic] = data
        if self.recording is not None:
            self.recording.write_many(messages)
        if self.flight is not None:
            self.flight.ring.add_many(messages)

    # --- /tf -----------------------------------------------------------------------------------

    def _write_tf(self) -> None:
        try:
            stamped = self._tf.message()
        except ValueError as exc:
            self.get_logger().warning(f'no /tf for this pose: {exc}', throttle_duration_sec=5.0)
            return
        if stamped is not None:
            self._store(TF, *stamped)

    # --- flight recorder ----------------------------------------------------------------------

    def _on_trigger(self, topic: str, data: bytes) -> None:
        """A /diagnostics array or a status topic's DiagnosticStatus: each status an event."""
        source, msg_type = self._triggers[topic]
        try:
            msg = deserialize_message(data, msg_type)
        except Exception as exc:  # rclpy raises a bare Exception for bytes it cannot read
            self.get_logger().warning(f'{topic}: unreadable message ignored: {exc}',
                                      throttle_duration_sec=5.0)
            return
        for status in (msg.status if msg_type is DiagnosticArray else [msg]):
            self._event(StatusEvent.of(source, status))

    def _event(self, event: StatusEvent) -> None:
        trigger = self._faults.check(event)
        flight = self.flight
        if trigger is None or flight is None or not flight.schedule(trigger, time.monotonic()):
            return
        self.get_logger().warning(f'flight recorder: {trigger.value} ({event.name or event.source})'
                                  f'; writing the last {flight.buffer_seconds:g} s in '
                                  f'{flight.post_trigger:g} s')

    def _housekeeping(self) -> None:
        trigger = self.flight.due(time.monotonic()) if self.flight is not None else None
        if trigger is not None:
            self.dump(trigger)

    def dump(self, trigger: RecorderTrigger, *, settle: float = 0.0) -> Path:
        """Write the flight recorder's window (in a thread, ``settle`` s from now) to a new bag
        folder; returns the path its MCAP file will have."""
        if self.flight is None:
            raise RuntimeError('the flight recorder is off (flight_recorder:=false)')

        def topics() -> list[TopicInfo]:
            with self._lock:
                return list(self._topics.values())
        return self.flight.dump(trigger, topics, settle=settle)

    def _on_save(self, request, response):
        try:
            # the nodes' taps send what they published up to now within a flush period
            path = self.dump(RecorderTrigger.OPERATOR,
                             settle=2.0 * TAP_FLUSH_PERIOD if self.use_taps else 0.0)
        except (RuntimeError, OSError) as exc:
            response.success, response.message = False, str(exc)
            return response
        response.success, response.message = True, str(path.resolve())
        return response

    def wait_for_dumps(self, timeout: float = 30.0) -> None:
        """Wait until every dump started so far is written (tests, shutdown)."""
        if self.flight is not None:
            self.flight.dumps.wait(timeout)

    # --- status ------------------------------------------------------------------------------

    def _report(self) -> None:
        status = RecorderStatus(
            recording=self.recording is not None, flight_recorder=self.flight is not None,
            topics=len(self._topics), tapped_topics=len(self._taps.tapped_topics),
            bad_bundles=self.bad_bundles, messages=self.messages,
            bytes_written=self.recording.bytes_written if self.recording is not None else 0,
            file=str(self.recording.path) if self.recording is not None else '',
            dropped_topics=tuple(sorted(self.dropped_topics)),
            **(self.flight.status_values() if self.flight is not None else {}))
        level = WARN if self.dropped_topics or self.bad_bundles else OK
        message = (f'{len(self._topics)} topics ({len(self._taps.tapped_topics)} from taps), '
                   f'{self.messages} messages'
                   + (f'; not recorded: {", ".join(sorted(self.dropped_topics))}'
                      if self.dropped_topics else '')
                   + (f'; {self.bad_bundles} malformed recording bundles ignored'
                      if self.bad_bundles else ''))
        self._diag.report(level, message, status)

    def destroy_node(self) -> None:
        # a dump under way gets half the process' shutdown deadline; the rest closes the recording
        self.wait_for_dumps(timeout=0.5 * SHUTDOWN_DEADLINE)
        if self.recording is not None:
            self.recording.close()
        super().destroy_node()


def main(args=None) -> None:
    run_nodes([RecorderNode], args)


if __name__ == '__main__':
    main()
