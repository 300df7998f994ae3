"""A test-side ROS process for the multi-host rig: it records what the robot does and acts as
the operator would, inside one network namespace (rrps_testing.netns_rig starts it there).

    python -m rrps_testing.netns_agent --name robot --record pose,actuators/command,grippers/state \
        --ros-args -r __ns:=/rrps

Records: one JSON line per message on stdout, ``{"topic", "t", "stamp", ...}``: ``t`` the receipt time
(``time.time()``: every namespace shares the host's wall clock), ``stamp`` the header stamp [s], then the
decoded fields of :data:`TOPICS`: ``p``, ``q`` (x-y-z-w), ``frame`` of poses; ``lengths`` (actuators/state at
most every 5 ms); ``closed`` of grippers/state (on a change, else once a second); ``values`` of statuses;
``data``; one record per /diagnostics status. Every agent publishes ``rig/heartbeat`` at 10 Hz: agents that
hear each other show that DDS connects their namespaces.

Commands: one JSON object a line on stdin, ``{"id": N, ...}``, each answered by ``{"reply": N, ...}``:
``deadman`` (teleop/enable at 20 Hz; on release 5 false samples, none with ``"silent": true``), ``call`` (a
std_srvs/Trigger service), ``activate`` (driver_node's activate, or false: deactivate), ``sender``
(``{"offset", "amplitude", "period"}``: target_pose at 50 Hz around home, stamped ``offset`` s ahead; null
stops), ``sender_late`` (its targets that many s late), ``round_trip`` (operator/round_trip_time at 4 Hz; null
stops), ``parameter`` (``{"node", "name", "value"}``: a string parameter, set as the viewer sets it),
``ping``, ``graph`` (the discovered graph's counts). It prints ``{"ready": true}`` once its endpoints exist.
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import sys
import threading
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParametersAtomically
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, String
from std_srvs.srv import Trigger

from rrps_description.geometry import load_robot
from rrps_interfaces.driver import gripper_states
from rrps_interfaces.status import source_node
from rrps_runtime.messages import lengths_from_joint_state, pose_from_msg, pose_to_msg, stamp_to_seconds
from rrps_runtime.process import make_executor, spin_until_shutdown
from rrps_runtime.qos import COMMAND_QOS, LATEST_QOS, STATE_QOS
from rrps_runtime.supervision import exit_with_parent

HEARTBEAT = 'rig/heartbeat'
#: command streams are best effort (as their publishers); a deep queue so that a busy agent
#: records every sample that arrived instead of only the newest
RECORD_COMMANDS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=200,
                             reliability=ReliabilityPolicy.BEST_EFFORT,
                             durability=DurabilityPolicy.VOLATILE)

#: topic -> (type, QoS, decoder name)
TOPICS = {
    'pose': (PoseStamped, LATEST_QOS, 'pose'),
    'target_pose': (PoseStamped, RECORD_COMMANDS, 'pose'),
    'master/pose': (PoseStamped, LATEST_QOS, 'pose'),
    'actuators/command': (JointState, RECORD_COMMANDS, 'lengths'),
    'actuators/state': (JointState, LATEST_QOS, 'lengths'),
    'grippers/state': (JointState, STATE_QOS, 'grippers'),
    'teleop/status': (DiagnosticStatus, STATE_QOS, 'status'),
    'climb/status': (DiagnosticStatus, STATE_QOS, 'status'),
    'teleop/enable': (Bool, RECORD_COMMANDS, 'data'),
    'operator/round_trip_time': (Float64, RECORD_COMMANDS, 'data'),
    '/diagnostics': (DiagnosticArray, STATE_QOS, 'diagnostics'),
}


class Agent(Node):
    """The rig agent's node: records the ``record`` topics as JSON lines and acts on the commands (module docstring)."""
    def __init__(self, name: str, record: list[str], *, context, out):
        super().__init__(f'rig_agent_{name}', context=context)
        self.name = name
        self._out = out
        self._lock = threading.Lock()
        self._last_state = 0.0
        self._last_grippers: tuple | None = None
        self._last_grippers_t = 0.0
        for topic in record:
            if topic not in TOPICS:
                raise SystemExit(f'unknown topic {topic!r}; known: {", ".join(TOPICS)}')
            kind, qos, decoder = TOPICS[topic]
            self.create_subscription(kind, topic, lambda msg, topic=topic, decoder=decoder:
                                     self._on_message(topic, decoder, msg), qos)
        self.create_subscription(String, HEARTBEAT, self._on_heartbeat, COMMAND_QOS)
        self._heartbeat = self.create_publisher(String, HEARTBEAT, COMMAND_QOS)
        self._enable = self.create_publisher(Bool, 'teleop/enable', COMMAND_QOS)
        self._target = self.create_publisher(PoseStamped, 'target_pose', COMMAND_QOS)
        self._round_trip_pub = self.create_publisher(Float64, 'operator/round_trip_time', COMMAND_QOS)
        self.round_trip: float | None = None
        self.sender_late = 0.0
        self._triggers: dict[str, object] = {}
        self._change_state = self.create_client(ChangeState, 'driver_node/change_state')
        self.deadman = False
        self._false_left = 0
        self.sender: dict | None = None
        self._sender_t0 = 0.0
        self._home = load_robot('pole_climber')
        self.commands: queue.SimpleQueue = queue.SimpleQueue()
        self.create_timer(0.1, lambda: self._heartbeat.publish(String(data=self.name)))
        self.create_timer(0.05, self._on_enable_tick)
        self.create_timer(0.02, self._on_tick)
        self.create_timer(0.25, lambda: self.round_trip is not None and self._round_trip_pub.publish(
            Float64(data=self.round_trip)))

    # --- output ----------------------------------------------------------------------------

    def emit(self, record: dict) -> None:
        line = json.dumps(record, separators=(',', ':'))
        with self._lock:
            self._out.write(line + '\n')
            self._out.flush()

    def _on_heartbeat(self, msg: String) -> None:
        if msg.data != self.name:
            self.emit({'topic': HEARTBEAT, 't': time.time(), 'source': msg.data})

    def _on_message(self, topic: str, decoder: str, msg) -> None:
        t = time.time()
        record: dict = {'topic': topic, 't': t}
        header = getattr(msg, 'header', None)
        if header is not None and topic != '/diagnostics':
            record['stamp'] = stamp_to_seconds(header.stamp)
        if decoder == 'pose':
            p, q = pose_from_msg(msg)
            record.update(p=[float(v) for v in p], q=[float(v) for v in q],
                          frame=msg.header.frame_id)
        elif decoder == 'lengths':
            if topic == 'actuators/state':
                if t - self._last_state < 0.005:
                    return
                self._last_state = t
            try:
                record['lengths'] = [float(v) for v in lengths_from_joint_state(msg)]
            except ValueError as exc:
                record['error'] = str(exc)
        elif decoder == 'grippers':
            closed = gripper_states(msg.name, msg.position)
            if closed is None:
                return
            key = tuple(sorted(closed.items()))
            if key == self._last_grippers and t - self._last_grippers_t < 1.0:
                return
            self._last_grippers, self._last_grippers_t = key, t
            record['closed'] = closed
        elif decoder == 'status':
            record['values'] = {kv.key: kv.value for kv in msg.values}
        elif decoder == 'data':
            record['data'] = msg.data if isinstance(msg.data, bool) else float(msg.data)
        elif decoder == 'diagnostics':
            for status in msg.status:
                self.emit({'topic': topic, 't': t, 'node': source_node(status.name),
                           'message': status.message,
                           'values': {kv.key: kv.value for kv in status.values}})
            return
        self.emit(record)

    # --- actions ---------------------------------------------------------------------------

    def _on_enable_tick(self) -> None:
        if self.deadman:
            self._enable.publish(Bool(data=True))
        elif self._false_left > 0:
            self._enable.publish(Bool(data=False))
            self._false_left -= 1

    def _on_tick(self) -> None:
        if self.sender is not None:
            s = self.sender
            t = time.monotonic() - self._sender_t0
            g = self._home
            p = g.home_position + [0.0, 0.0, s['amplitude'] * math.sin(2 * math.pi * t / s['period'])]
            msg = pose_to_msg(p, g.home_quaternion_xyzw, frame_id='ring_a',
                              stamp=self.get_clock().now().to_msg())
            ns = self.get_clock().now().nanoseconds + int((s['offset'] - self.sender_late) * 1e9)
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 10**9)
            self._target.publish(msg)
        while True:
            try:
                command = self.commands.get_nowait()
            except queue.Empty:
                return
            self._run(command)

    def _reply(self, command: dict, **values) -> None:
        self.emit({'reply': command.get('id'), 't': time.time(), **values})

    def _run(self, command: dict) -> None:
        if 'deadman' in command:
            self.deadman = bool(command['deadman'])
            if not self.deadman:
                self._false_left = 0 if command.get('silent') else 5
            self._reply(command, ok=True)
        elif 'call' in command:
            name = command['call']
            client = self._triggers.get(name)
            if client is None:
                client = self._triggers[name] = self.create_client(Trigger, name)
            self._call(command, client, Trigger.Request(),
                       lambda r: {'success': r.success, 'message': r.message})
        elif 'activate' in command:
            transition = (Transition.TRANSITION_ACTIVATE if command['activate']
                          else Transition.TRANSITION_DEACTIVATE)
            self._call(command, self._change_state,
                       ChangeState.Request(transition=Transition(id=transition)),
                       lambda r: {'success': r.success, 'message': ''})
        elif 'sender' in command:
            self.sender = command['sender']
            self._sender_t0 = time.monotonic()
            self._reply(command, ok=True)
        elif 'sender_late' in command:
            self.sender_late = float(command['sender_late'])
            self._reply(command, ok=True)
        elif 'round_trip' in command:
            value = command['round_trip']
            self.round_trip = None if value is None else float(value)
            self._reply(command, ok=True)
        elif 'parameter' in command:
            p = command['parameter']
            service = f"{p['node']}/set_parameters_atomically"
            client = self._triggers.get(service)
            if client is None:
                client = self._triggers[service] = self.create_client(SetParametersAtomically, service)
            value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=str(p['value']))
            self._call(command, client, SetParametersAtomically.Request(
                parameters=[Parameter(name=p['name'], value=value)]),
                lambda r: {'successful': r.result.successful, 'reason': r.result.reason})
        elif 'ping' in command:
            self._reply(command, ok=True)
        elif 'graph' in command:
            topics = self.get_topic_names_and_types()
            self._reply(command, nodes=len(self.get_node_names()), topics=len(topics),
                        services=len(self.get_service_names_and_types()),
                        endpoints=sum(self.count_publishers(t) + self.count_subscribers(t) for t, _ in topics))
        else:
            self._reply(command, ok=False, error=f'unknown command {command}')

    def _call(self, command: dict, client, request, read) -> None:
        if not client.service_is_ready():
            self._reply(command, success=False, message=f'service {client.srv_name} not available')
            return
        future = client.call_async(request)
        deadline = time.monotonic() + float(command.get('timeout', 10.0))

        def done(fut) -> None:
            result = fut.result()
            if result is None:
                self._reply(command, success=False, message='no response')
            else:
                self._reply(command, **read(result))
        future.add_done_callback(done)

        def expire() -> None:
            if not future.done() and time.monotonic() > deadline:
                future.cancel()
                self._reply(command, success=False, message='timed out')
        timer = self.create_timer(1.0, lambda: (expire(), future.done() and timer.cancel()))


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    p = argparse.ArgumentParser(description='rrps multi-host rig agent')
    p.add_argument('--name', required=True)
    p.add_argument('--record', default='', help='comma-separated topics (see the docstring)')
    args = p.parse_args(argv[:split])
    stop = threading.Event()
    exit_with_parent(stop.set)
    context = rclpy.Context()
    rclpy.init(args=['agent', *argv[split:]], context=context,
               signal_handler_options=SignalHandlerOptions.NO)
    import signal
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    node = Agent(args.name, [t for t in args.record.split(',') if t], context=context,
                 out=sys.stdout)

    def read_stdin() -> None:
        for line in sys.stdin:
            line = line.strip()
            if line:
                try:
                    node.commands.put(json.loads(line))
                except json.JSONDecodeError as exc:
                    node.emit({'reply': None, 'ok': False, 'error': str(exc)})
        stop.set()  # the test is gone

    threading.Thread(target=read_stdin, daemon=True).start()
    # the events executor, as the product's nodes: recording a few hundred messages a second
    # costs a fraction of what one spin_once per message does (two cores run the whole rig)
    executor = make_executor(context, 'events')
    executor.add_node(node)
    node.emit({'ready': True, 't': time.time(), 'name': args.name})
    try:
        spin_until_shutdown(executor, context, stop, period=0.05)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    return 0


if __name__ == '__main__':
    sys.exit(main())
