"""foxglove_node: the robot live in Foxglove, through the Foxglove SDK's WebSocket server.

Topics are found in the ROS graph every ``discovery_period`` s and bridged as received (raw CDR, the recorder's
``ros2msg`` schemas: :func:`rrps_recording.storage.schemas.message_schema`) with the QoS that hears every
publisher (rosbag2's rule), each at most ``max_rate`` times a second except the ``unthrottled`` ones. A
transient-local topic's newest message is sent again when a client subscribes, to every client then subscribed
(a client may get it twice). The recording taps' bundles are not bridged.

Read-only, always: the server advertises no capability, so nothing a Foxglove client sends reaches ROS. It
listens on ``host`` (127.0.0.1; set ``0.0.0.0`` deliberately to let the network in). See docs/recording.md.
"""

from __future__ import annotations

import time

import foxglove
import foxglove.websocket
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy

from rrps_interfaces.kinematics import ROBOT_DESCRIPTION
from rrps_interfaces.recording import RECORDING_TAP, TF, TF_STATIC
from rrps_interfaces.status import DIAGNOSTICS
from rrps_recording.storage.schemas import message_class, message_schema
from rrps_recording.topic_graph import offered, selected, subscription_for
from rrps_recording.transport.throttle import Throttle
from rrps_runtime.diagnostics import OK, OPERATOR_STATION, WARN, Diagnostics
from rrps_runtime.parameter_schema import NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes

__all__ = ['FoxgloveNode', 'main']

#: The absolute topics bridged with the namespace's.
_ABSOLUTE = (DIAGNOSTICS, TF, TF_STATIC, f'/{ROBOT_DESCRIPTION}')

#: foxglove_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('foxglove_node', 'rrps_recording', [
    Parameter('host', '127.0.0.1', 'address the WebSocket server listens on (127.0.0.1: this machine only)'),
    Parameter('port', 8765, 'WebSocket server port (0: any free port)', range=(0, 65535)),
    Parameter('topics', ('',), "topics or prefixes to bridge ('' = the node's namespace, /diagnostics, /tf, "
              '/tf_static, /robot_description)'),
    Parameter('max_rate', 30.0, 'each topic sent at most this often (the newest message)', unit='Hz',
              range=(0.1, 1000.0)),
    Parameter('unthrottled', ('/diagnostics', 'robot_description', '/robot_description'),
              'topics sent whole (relative names are in the namespace)'),
    Parameter('discovery_period', 1.0, 'graph discovery period', unit='s', range=(0.05, 60.0)),
    Parameter('depth', 10, 'subscription queue depth', range=(1, 10000)),
])


class _ReadOnly(foxglove.websocket.ServerListener):
    """Counts what clients subscribe to and notes the topics newly subscribed (the server's
    thread); a client publish (never advertised) is only counted."""

    def __init__(self):
        self.subscriptions: dict[int, set[int]] = {}
        self.subscribed: set[str] = set()
        self.refused = 0

    def on_subscribe(self, client, channel) -> None:
        self.subscriptions.setdefault(client.id, set()).add(channel.id)
        self.subscribed.add(channel.topic)

    def on_unsubscribe(self, client, channel) -> None:
        self.subscriptions.get(client.id, set()).discard(channel.id)

    def on_client_advertise(self, client, channel) -> None:
        self.refused += 1

    def on_message_data(self, client, client_channel_id, data) -> None:
        self.refused += 1


class FoxgloveNode(Node):
    """Bridges the robot's topics to Foxglove, read-only; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('foxglove_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.topics = list(values['topics'])
        self.depth = values['depth']
        ns = self.get_namespace().rstrip('/')
        self.throttle = Throttle(values['max_rate'], (name if name.startswith('/') else f'{ns}/{name}'
                                                      for name in values['unthrottled'] if name))
        self.channels: dict[str, foxglove.Channel] = {}
        self._bridged: dict[str, object] = {}
        self.skipped: dict[str, str] = {}
        self._latched: dict[str, bytes] = {}  # the newest message of transient-local topics
        self._sdk_context = foxglove.Context()
        self._listener = _ReadOnly()
        self.server = foxglove.start_server(
            name=f'rrps {ns or "/"}', host=values['host'], port=values['port'], capabilities=[],
            server_listener=self._listener, context=self._sdk_context)
        self.port = self.server.port
        self._diag = Diagnostics(self, 'foxglove bridge', hardware_id=OPERATOR_STATION, rate_hz=1.0)
        self.create_timer(values['discovery_period'], self._discover)
        self.create_timer(min(0.05, self.throttle.period), self._send_due)
        self.create_timer(1.0, self._report)
        self._discover()
        self.get_logger().info(f'Foxglove WebSocket server on ws://{values["host"]}:{self.port} '
                               '(read-only: no client publishing)')

    def _selected(self, name: str) -> bool:
        return (not name.endswith('/' + RECORDING_TAP)
                and selected(name, self.get_namespace(), self.topics, _ABSOLUTE))

    def _discover(self) -> None:
        """A channel and a raw subscription for every selected topic that has a publisher."""
        for name, types in self.get_topic_names_and_types():
            if name in self._bridged or not self._selected(name):
                continue
            infos = self.get_publishers_info_by_topic(name)
            if not infos:
                continue
            if len(types) != 1:
                self.skipped[name] = f'several types {list(types)}'
                continue
            try:
                cls = message_class(types[0])
                schema = message_schema(types[0])
            except (ImportError, AttributeError, ValueError, LookupError) as exc:
                self.skipped[name] = f'{types[0]}: {exc}'
                continue
            self.skipped.pop(name, None)
            qos = subscription_for(offered(infos), self.depth)
            if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
                self._latched[name] = b''
            self.channels[name] = foxglove.Channel(
                name, schema=foxglove.Schema(name=types[0], encoding='ros2msg', data=schema.encode('utf-8')),
                message_encoding='cdr', context=self._sdk_context)
            self._bridged[name] = self.create_subscription(
                cls, name, lambda data, name=name: self._on_message(name, data), qos, raw=True)

    def _on_message(self, topic: str, data: bytes) -> None:
        if topic in self._latched:
            self._latched[topic] = data
        if self.throttle.offer(topic, data, time.monotonic()):
            self.channels[topic].log(data, log_time=time.time_ns())

    def _send_due(self) -> None:
        """The held messages now due, and a latched topic's newest message again once a client
        subscribed to it (as a transient-local publisher gives it to a late subscriber)."""
        for topic, data in self.throttle.due(time.monotonic()):
            self.channels[topic].log(data, log_time=time.time_ns())
        while self._listener.subscribed:
            topic = self._listener.subscribed.pop()
            if self._latched.get(topic):
                self.channels[topic].log(self._latched[topic], log_time=time.time_ns())

    def _report(self) -> None:
        clients = sum(1 for channels in self._listener.subscriptions.values() if channels)
        level = WARN if self.skipped or self._listener.refused else OK
        message = (f'{len(self.channels)} topics on port {self.port}, {clients} clients subscribed'
                   + (f'; not bridged: {", ".join(sorted(self.skipped))}' if self.skipped else '')
                   + (f'; {self._listener.refused} client publishes refused' if self._listener.refused else ''))
        self._diag.report(level, message, {'port': self.port, 'topics': len(self.channels),
                                           'clients': clients, 'sent': self.throttle.passed,
                                           'dropped_by_rate': self.throttle.dropped,
                                           'client_publishes_refused': self._listener.refused,
                                           'not_bridged': ', '.join(sorted(self.skipped))})

    def destroy_node(self) -> None:
        self.server.stop()
        for channel in self.channels.values():
            channel.close()
        super().destroy_node()


def main(args=None) -> None:
    run_nodes([FoxgloveNode], args)


if __name__ == '__main__':
    main()
