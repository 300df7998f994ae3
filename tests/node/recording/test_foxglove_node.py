"""foxglove_node seen from a client that speaks the Foxglove WebSocket protocol itself (the
``websockets`` library): serverInfo and advertise, subscribe,
binary message data decoded with mcap-ros2's decoder from the advertised schema and with rclpy,
compared with what was published; each topic at most ``max_rate``, the newest message last; a
latched robot_description; and a client that tries to publish reaches nothing in ROS.

The client offers both names of the protocol; the pinned SDK's server accepts only
``foxglove.sdk.v1`` (it refuses ``foxglove.websocket.v1`` alone with HTTP 400), the same
operations and binary framing under the name the Foxglove app now asks for."""

from __future__ import annotations

import asyncio
import json
import os
import secrets
import struct
import time

import pytest

from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'
MAX_RATE = 20.0


SUBPROTOCOLS = ('foxglove.sdk.v1', 'foxglove.websocket.v1')


class Client:
    """The client side of the protocol: JSON text operations, binary message data
    (opcode 1: subscription id u32, receive time u64, payload)."""

    def __init__(self, socket):
        self.socket = socket
        self.server_info = None
        self.channels: dict[str, dict] = {}
        self.statuses: list[dict] = []
        self.messages: dict[int, list[tuple[int, bytes]]] = {}

    async def receive(self, seconds: float, until=None) -> None:
        """Handle what the server sends for ``seconds`` (or until ``until()``)."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline and not (until and until()):
            try:
                frame = await asyncio.wait_for(self.socket.recv(), timeout=deadline - time.monotonic())
            except asyncio.TimeoutError:
                return
            if isinstance(frame, bytes):
                assert frame[0] == 1, f'unexpected binary opcode {frame[0]}'
                subscription, stamp = struct.unpack_from('<IQ', frame, 1)
                self.messages.setdefault(subscription, []).append((stamp, frame[13:]))
                continue
            op = json.loads(frame)
            if op['op'] == 'serverInfo':
                self.server_info = op
            elif op['op'] == 'advertise':
                self.channels.update({c['topic']: c for c in op['channels']})
            elif op['op'] == 'status':
                self.statuses.append(op)

    async def subscribe(self, topics: dict[int, str]) -> None:
        await self.socket.send(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': sid, 'channelId': self.channels[topic]['id']} for sid, topic in topics.items()]}))


def _decoder(channel: dict):
    from mcap_ros2._dynamic import generate_dynamic
    return generate_dynamic(channel['schemaName'], channel['schema'])[channel['schemaName']]


def test_a_foxglove_client_sees_the_topics_at_a_bounded_rate_and_cannot_publish(ros_context):
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import String
    from websockets.asyncio.client import connect
    from websockets.typing import Subprotocol

    from rrps_recording.nodes.foxglove_node import FoxgloveNode
    from rrps_runtime.messages import pose_to_msg
    probe = Probe(context=ros_context, namespace=NS)
    pose_pub = probe.publisher(PoseStamped, 'pose')
    description = '<robot name="pole_climber"/>'
    latched = probe.create_publisher(String, 'robot_description',
                                     QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    latched.publish(String(data=description))
    commands = probe.collect(PoseStamped, 'target_pose')
    bridge = FoxgloveNode(context=ros_context, namespace=NS, parameter_overrides=[
        Parameter('port', value=0), Parameter('max_rate', value=MAX_RATE),
        Parameter('discovery_period', value=0.1)])
    sent: list[PoseStamped] = []

    def publish_poses(seconds: float) -> None:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:  # 200 Hz, ten times the bridge's rate
            msg = pose_to_msg([0.0, 0.0, 0.4 + 1e-5 * len(sent)], [0.0, 0.0, 0.0, 1.0],
                              frame_id='ring_a', stamp=probe.get_clock().now().to_msg())
            pose_pub.publish(msg)
            sent.append(msg)
            time.sleep(0.005)

    async def session() -> Client:
        async with connect(f'ws://127.0.0.1:{bridge.port}',
                           subprotocols=[Subprotocol(p) for p in SUBPROTOCOLS]) as socket:
            assert socket.subprotocol == 'foxglove.sdk.v1'
            client = Client(socket)
            await client.receive(10.0, until=lambda: {f'{NS}/pose', f'{NS}/robot_description'}
                                 <= set(client.channels))
            await client.subscribe({1: f'{NS}/pose', 2: f'{NS}/robot_description'})
            await client.receive(0.5)
            await asyncio.get_running_loop().run_in_executor(None, publish_poses, 2.0)
            await client.receive(1.0)
            # a client publish: advertise a channel on the command topic and send on it
            await socket.send(json.dumps({'op': 'advertise', 'channels': [
                {'id': 7, 'topic': f'{NS}/target_pose', 'encoding': 'cdr',
                 'schemaName': 'geometry_msgs/msg/PoseStamped'}]}))
            await socket.send(b'\x01' + struct.pack('<I', 7) + serialize_message(sent[-1]))
            await client.receive(1.0)
            return client

    with Spinner(ros_context, [bridge, probe]):
        assert wait_for(lambda: f'{NS}/pose' in bridge.channels)
        client = asyncio.run(session())
        time.sleep(0.5)
        publishers = probe.count_publishers(f'{NS}/target_pose')
    # serverInfo: no capability, so no client publishing, services or parameters
    assert client.server_info is not None and client.server_info['capabilities'] == []
    pose_channel = client.channels[f'{NS}/pose']
    assert (pose_channel['encoding'], pose_channel['schemaName'], pose_channel['schemaEncoding']) == \
        ('cdr', 'geometry_msgs/msg/PoseStamped', 'ros2msg')
    # the latched description reached a bridge that started after it was published (twice if
    # the client subscribed as it arrived: once as it came, once again for the new subscriber)
    decode_description = _decoder(client.channels[f'{NS}/robot_description'])
    assert 1 <= len(client.messages[2]) <= 2, client.messages[2]
    assert all(decode_description(data).data == description for _, data in client.messages[2])
    # poses: values as published (both decoders), in order, at most MAX_RATE a second, the last last
    poses = client.messages[1]
    decode = _decoder(pose_channel)
    zs = [decode(data).pose.position.z for _, data in poses]
    assert zs == [deserialize_message(data, PoseStamped).pose.position.z for _, data in poses]
    sent_z = [m.pose.position.z for m in sent]
    assert zs == sorted(zs) and set(zs) <= set(sent_z)
    assert zs[-1] == sent_z[-1]  # the newest of a burst is never held back
    stamps = [s * 1e-9 for s, _ in poses]
    span = stamps[-1] - stamps[0]
    assert len(poses) <= MAX_RATE * span + 2, (len(poses), span)
    assert len(poses) >= 0.5 * MAX_RATE * 2.0  # about the bound, not a trickle
    # nothing a client sent reached ROS
    # the server refused the client's channel and its message, and nothing reached ROS
    errors = [st['message'] for st in client.statuses if st['level'] == 2]
    assert any('clientPublish' in e for e in errors) and any('Unknown channel' in e for e in errors)
    assert publishers == 0 and list(commands) == []
