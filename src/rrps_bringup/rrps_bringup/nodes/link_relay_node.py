"""link_relay_node: the robot's state for the operator station, within the link's budget.

Runs on the robot host, in the robot's namespace, and republishes the robot's topics on the link topics of
:mod:`rrps_interfaces.link` at the rates of its parameters (the link profile; a rate of 0 relays nothing), through
the gates of :mod:`rrps_bringup.link_budget`. State streams are passed on as serialised bytes, never decoded.
Commands are not relayed. Topics, rates and QoS: docs/deployment.md, "Field links".
"""

from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TransformStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from rrps_bringup.link_budget import ChangeGate, RateGate, StatusTable
from rrps_description.geometry import load_robot
from rrps_description.names import RINGS
from rrps_interfaces.climb import SUPPORT_POSE, odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE
from rrps_interfaces.link import LINK_DIAGNOSTICS, LINK_TOPICS, LinkRelayStatus
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_runtime.diagnostics import OK, Diagnostics
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATEST_QOS, LINK_EVENT_QOS, LINK_STATE_QOS, STATE_QOS

__all__ = ['PARAMETERS', 'LinkRelayNode', 'main']

_RATE = (0.0, 1000.0)
#: link_relay_node's parameters: the link profile (the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('link_relay_node', 'rrps_bringup', [
    ROBOT,
    Parameter('pose_rate', 50.0, 'link/pose rate (teleop feedback and the viewer); 0: not relayed',
              unit='Hz', range=_RATE),
    Parameter('state_rate', 20.0, 'link/actuators/state rate (the viewer: legs, forces, plot); 0: not '
              'relayed', unit='Hz', range=_RATE),
    Parameter('target_rate', 10.0, "link/target_pose rate (the viewer's ghost); 0: not relayed", unit='Hz',
              range=_RATE),
    Parameter('odometry_rate', 10.0, 'link/odometry/ring_a|ring_b|support rate (the viewer, the load guards); '
              '0: not relayed',
              unit='Hz', range=_RATE),
    Parameter('grippers_rate', 2.0, 'link/grippers/state rate while no gripper changes (a change goes at '
              'once); 0: not relayed', unit='Hz', range=_RATE),
    Parameter('diagnostics_period', 0.5, 'link/diagnostics period while no status changes (a change goes '
              'within 0.1 s)', unit='s', range=(0.1, 60.0)),
    Parameter('diagnostics_nodes', ('driver_node', 'ik_node', 'fk_node', 'climb_node', 'recorder_node'),
              "the robot's nodes whose statuses go on link/diagnostics"),
])

#: robot topic -> (message type, QoS of the robot's topic as this relay reads it, rate parameter)
_STREAMS = {
    POSE: (PoseStamped, LATEST_QOS, 'pose_rate'),
    ACTUATORS_STATE: (JointState, LATEST_QOS, 'state_rate'),
    TARGET_POSE: (PoseStamped, COMMAND_QOS, 'target_rate'),
    **{odometry_topic(ring): (PoseStamped, LATEST_QOS, 'odometry_rate') for ring in RINGS},
    SUPPORT_POSE: (TransformStamped, LATEST_QOS, 'odometry_rate'),
}


class LinkRelayNode(Node):
    """The robot's state on the link topics, at the link profile's rates (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('link_relay_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.samples_in = 0
        self.samples_out = 0
        self._out: dict[str, int] = {}
        for topic, (kind, qos, rate) in _STREAMS.items():
            gate = RateGate(values[rate])
            if not gate.enabled:
                continue
            pub = self.create_publisher(kind, LINK_TOPICS[topic], LINK_STATE_QOS)
            self.create_subscription(kind, topic, lambda data, gate=gate, pub=pub, topic=topic:
                                     self._relay(data, gate, pub, topic), qos, raw=True)
        self._grippers_gate = ChangeGate(values['grippers_rate'])
        if self._grippers_gate.enabled:
            self._grippers_pub = self.create_publisher(JointState, LINK_TOPICS[GRIPPERS_STATE], LINK_EVENT_QOS)
            self.create_subscription(JointState, GRIPPERS_STATE, self._on_grippers, STATE_QOS)
        self._statuses = StatusTable(values['diagnostics_nodes'], period=values['diagnostics_period'])
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, LINK_DIAGNOSTICS, LINK_EVENT_QOS)
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, STATE_QOS)
        self.create_timer(0.05, self._send_statuses)
        self._diag = Diagnostics(self, 'link relay', hardware_id=load_robot(values['robot']).name, rate_hz=1.0)
        self._window = (time.monotonic(), 0, {})
        self.create_timer(1.0, self._report)

    def _count(self, topic: str) -> None:
        self.samples_out += 1
        self._out[topic] = self._out.get(topic, 0) + 1

    def _relay(self, data: bytes, gate: RateGate, pub, topic: str) -> None:
        self.samples_in += 1
        if gate.admit(time.monotonic()):
            pub.publish(data)
            self._count(topic)

    def _on_grippers(self, msg: JointState) -> None:
        self.samples_in += 1
        if self._grippers_gate.admit(time.monotonic(), (tuple(msg.name), tuple(msg.position))):
            self._grippers_pub.publish(msg)
            self._count(GRIPPERS_STATE)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self._statuses.offer(source_node(status.name), status.name, (bytes(status.level), status.message), status)

    def _send_statuses(self) -> None:
        t = time.monotonic()
        if self._statuses.due(t):
            msg = DiagnosticArray(status=self._statuses.take(t))
            msg.header.stamp = self.get_clock().now().to_msg()
            self._diagnostics_pub.publish(msg)
            self._count(DIAGNOSTICS)

    def _report(self) -> None:
        t0, out0, per0 = self._window
        now = time.monotonic()
        dt = max(now - t0, 1e-3)
        rates = {topic: (n - per0.get(topic, 0)) / dt for topic, n in self._out.items()}
        self._window = (now, self.samples_out, dict(self._out))
        self._diag.report(OK, 'relaying', LinkRelayStatus(
            samples_in=self.samples_in, samples_out=self.samples_out,
            pose_rate=round(rates.get(POSE, 0.0), 1), state_rate=round(rates.get(ACTUATORS_STATE, 0.0), 1),
            out_rate=round((self.samples_out - out0) / dt, 1)))


def main(args=None) -> None:
    run_nodes([LinkRelayNode], args)


if __name__ == '__main__':
    main()
