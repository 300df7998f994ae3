"""teleop_node: the slave follows the master (pure core: :mod:`rrps_teleop.mapping`).

Topics and parameters: docs/usage.md, 'The ROS interface', and docs/parameters.md; the mapping,
guards and holds: docs/architecture.md, 'rrps_teleop'. The robot driven is the one in
``robot_namespace`` (a change switches robots: :meth:`rrps_teleop.mapping.TeleopMapping.switch_slave`),
read directly or over its link relay. The slave's stale ``pose``, an inactive driver or the
operator's round trip above ``hold_latency`` disengage the mapping; the targets are streamed
jerk-limited (:mod:`rrps_teleop.teleop_stream`), the feedback by :mod:`rrps_teleop.master_feedback`,
the load guards' support by :mod:`rrps_teleop.load_support`. Settable parameters are validated;
any change is a clutch.
"""

from __future__ import annotations

import math
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.world import Support
from rrps_interfaces.climb import CLIMB_STATUS, ClimbState, ClimbStatus
from rrps_interfaces.driver import DriverStatus
from rrps_interfaces.kinematics import ACTUATORS_COMMAND, POSE, TARGET_POSE
from rrps_interfaces.link import namespaced, normalize_namespace, robot_topic
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_interfaces.teleop import (
    MASTER_POSE,
    MASTER_STATE,
    OPERATOR_ROUND_TRIP,
    TELEOP_ENABLE,
    TELEOP_STATUS,
    TeleopCode,
    TeleopStatus,
)
from rrps_runtime.diagnostics import ERROR, OK, STALE, WARN, Diagnostics
from rrps_runtime.freshness import CommandFreshness, StaleCommand
from rrps_runtime.messages import lengths_from_joint_state, pose_from_msg, stamp_to_seconds
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATEST_QOS, LINK_EVENT_QOS, LINK_STATE_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_teleop.fixture import FixtureConfig
from rrps_teleop.mapping import TeleopConfig, TeleopMapping, TeleopOutput
from rrps_teleop.master_feedback import MasterFeedback
from rrps_teleop.support_input import SupportInput
from rrps_teleop.teleop_config import CONFIG_PARAMETERS, PARAMETERS
from rrps_teleop.teleop_stream import StreamOutput

__all__ = ['TeleopNode', 'main']

WATCHDOG_PERIOD = 0.02
#: the names of the parameters that are TeleopConfig's fields.
_CONFIG_NAMES = frozenset(p.name for p in CONFIG_PARAMETERS)
_LEVELS = {
    TeleopCode.NO_WARNING: OK, TeleopCode.SPEED_LIMITED: OK, TeleopCode.DEADMAN_RELEASED: OK,
    TeleopCode.CLIMB_EXECUTING: OK, TeleopCode.MASTER_STALE: STALE,
    TeleopCode.WAITING_FOR_SLAVE_POSE: STALE, TeleopCode.INVALID: ERROR,
    TeleopCode.SLAVE_STATE_LOST: ERROR, TeleopCode.LINK_LATENCY: WARN,
    TeleopCode.DRIVER_INACTIVE: WARN, TeleopCode.LATENCY_SLOWED: OK,
}


class TeleopNode(Node):
    """Master → slave mapping with clutch, deadman and guards; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('teleop_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)  # the schema: rrps_teleop.teleop_config
        self.geometry = load_robot(values['robot'])
        if values['payload_mass'] is not None:  # the load guards' payload (else the robot's own)
            self.geometry = self.geometry.with_(payload=Payload(
                ring=values['payload_ring'], mass=values['payload_mass'], com=np.array(values['payload_com'])))
        self.frame_id = values['frame_id']
        self.master_frame_id = values['master_frame_id']
        self.control = values['control']
        config = {name: values[name] for name in _CONFIG_NAMES}
        if config['singularity_halt'] is None:  # unset: the robot's, which the parameter then shows
            config['singularity_halt'] = float(self.geometry.min_conditioning)
            self.set_parameters([Parameter('singularity_halt', value=config['singularity_halt'])])
        start = Support.of(values['support'], values['world_q_support'])
        self.mapping = TeleopMapping(self.geometry, TeleopConfig(**config), support=start)
        self._support = SupportInput(self, self.mapping.loads, start)
        self._pending: TeleopConfig | None = None
        self._last_status: tuple | None = None
        self._last_status_time = -math.inf
        self._status_period = 1.0 / values['status_rate']
        self._output = TeleopOutput(TeleopCode.DEADMAN_RELEASED, False, 'waiting for teleop/enable')
        self._diag = Diagnostics(self, 'teleop', hardware_id=self.geometry.name)
        self._tap = RecordingTap(self)
        self._robot_topics = values['robot_topics']
        self._slave_stamp: float | None = None
        self._robot_publishers: dict[str, tuple] = {}
        self._stream = StreamOutput(self, self.geometry, jerk_limited=values['jerk_limited'], frame_id=self.frame_id,
                                    publishers=lambda: (self._target_pub, self._command_pub))
        self._robot_subscriptions: list = []
        self._attach_robot(values['robot_namespace'])
        self._master_subscription = None
        self._subscribe_master_input()
        self.create_subscription(Bool, TELEOP_ENABLE, self._on_enable, COMMAND_QOS)
        self.create_subscription(Float64, OPERATOR_ROUND_TRIP, self._on_round_trip, COMMAND_QOS)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._feedback = MasterFeedback(self, self._tap, self.mapping, self.geometry, frame_id=self.master_frame_id,
                                        fixture=FixtureConfig(stiffness=values['fixture_stiffness']),
                                        scale=values['feedback_scale'], rate=values['feedback_rate'])
        self.create_timer(WATCHDOG_PERIOD, self._watchdog)
        if self.control == 'timer':
            self.create_timer(1.0 / values['control_rate'], self._control)

    # --- parameters ----------------------------------------------------------------------

    def _check_parameters(self, parameters) -> SetParametersResult:
        """Validate the whole new configuration (TeleopConfig raises ValueError with the reason)."""
        for p in parameters:
            if p.name == 'robot_namespace':
                try:
                    normalize_namespace(p.value)
                except ValueError as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
        changes = {p.name: (list(p.value) if PARAMETERS[p.name].type is tuple else p.value)
                   for p in parameters if p.name in _CONFIG_NAMES}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            self._pending = self.mapping.config.with_(**changes)
        except (TypeError, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        for p in parameters:
            if p.name == 'robot_namespace':
                self._switch_robot(p.value)
        if self._pending is not None and any(p.name in _CONFIG_NAMES for p in parameters):
            self.mapping.configure(self._pending)  # a clutch: the next engage re-indexes
            self._pending = None
            self._subscribe_master_input()
            self._master_freshness.timeout = self.mapping.config.master_timeout
            self.get_logger().info(f'teleop parameters changed: mode {self.mapping.config.mode}, '
                                   f'translation_scale {self.mapping.config.translation_scale:g}, '
                                   f'rotation_mode {self.mapping.config.rotation_mode} (clutch released)')
            self._publish_status(TeleopOutput(self._output.code, False, 'parameters changed: clutch released'))

    # --- the driven robot ----------------------------------------------------------------

    def _attach_robot(self, namespace: str) -> None:
        """Read and command the robot whose topics are in ``namespace`` ('': this node's own):
        its pose, climb status and driver status (direct or over its link relay), its
        target_pose / actuators/command and teleop/status (the climb node's sign that the
        operator station is there). Publishers are kept for a switch back."""
        for subscription in self._robot_subscriptions:
            self.destroy_subscription(subscription)
        ns = normalize_namespace(namespace)
        ns = '' if ns == self.get_namespace() else ns
        #: the driven robot's namespace (absolute)
        self.robot_namespace = ns or self.get_namespace()
        if ns not in self._robot_publishers:
            self._robot_publishers[ns] = (
                self._tap.create_publisher(PoseStamped, namespaced(TARGET_POSE, ns), COMMAND_QOS),
                self._tap.create_publisher(JointState, namespaced(ACTUATORS_COMMAND, ns), COMMAND_QOS),
                self.create_publisher(DiagnosticStatus, namespaced(TELEOP_STATUS, ns), STATE_QOS))
        self._target_pub, self._command_pub, self._status_pub = self._robot_publishers[ns]
        link = self._robot_topics == 'link'
        self._robot_subscriptions = [
            self.create_subscription(PoseStamped, robot_topic(POSE, ns, self._robot_topics), self._on_slave_pose,
                                     LINK_STATE_QOS if link else LATEST_QOS),
            self.create_subscription(DiagnosticStatus, namespaced(CLIMB_STATUS, ns), self._on_climb_status,
                                     STATE_QOS),
            self.create_subscription(DiagnosticArray, robot_topic(DIAGNOSTICS, ns, self._robot_topics),
                                     self._on_diagnostics, LINK_EVENT_QOS if link else STATE_QOS),
            *self._support.attach(ns, self._robot_topics)]

    def _switch_robot(self, namespace: str) -> None:
        """Drive another robot: the clutch releases (the old robot holds: no more commands),
        its last teleop/status says so, and the deadman must be released and pressed again."""
        old = self.robot_namespace
        self.mapping.switch_slave()
        self._stream.reset()
        self._slave_stamp = None
        self._publish_status(TeleopOutput(TeleopCode.DEADMAN_RELEASED, False, 'switched to another robot'),
                             force=True)
        self._attach_robot(namespace)
        self.get_logger().info(f'driving the robot in {self.robot_namespace} (was {old}): clutch released, '
                               'release the deadman and press it again')
        self._publish_status(TeleopOutput(TeleopCode.DEADMAN_RELEASED, False,
                                          'robot switched: release the deadman and press it again'), force=True)

    # --- inputs --------------------------------------------------------------------------

    def _subscribe_master_input(self) -> None:
        """Subscribe the one master input the mode maps: master/pose (Cartesian mode) or
        master/actuators/state (joint mode); both stream at the master's rate, and taking the
        unused one would cost every control step its delivery. Runs in the executor's thread
        (start-up, the parameter callback), never concurrently with a callback."""
        cartesian = self.mapping.config.mode == 'cartesian'
        topic = MASTER_POSE if cartesian else MASTER_STATE
        if self._master_subscription is not None:
            if self._master_subscription.topic_name == self.resolve_topic_name(topic):
                return
            self.destroy_subscription(self._master_subscription)
        self._master_freshness = CommandFreshness(self.mapping.config.master_timeout)  # a new stream
        self._master_subscription = (
            self.create_subscription(PoseStamped, topic, self._on_master_pose, STATE_QOS) if cartesian
            else self.create_subscription(JointState, topic, self._on_master_state, STATE_QOS))

    def _on_master_pose(self, msg: PoseStamped) -> None:
        if msg.header.frame_id != self.master_frame_id:
            self._reject(f'master/pose frame_id {msg.header.frame_id!r} is not {self.master_frame_id!r}')
            return
        try:
            self.mapping.on_master_pose(time.monotonic(), *pose_from_msg(msg), **self._sample_time(msg))
        except StaleCommand as exc:
            self._late('master/pose', exc)
            return
        except ValueError as exc:
            self._reject(f'master/pose: {exc}')
            return
        if self.control == 'message' and self.mapping.config.mode == 'cartesian':
            self._control()

    def _sample_time(self, msg) -> dict:
        """A master sample's stamp and its age on receipt (an unstamped one counts from its
        receipt); StaleCommand when it came later than ``master_timeout``."""
        stamp = stamp_to_seconds(msg.header.stamp)
        if not stamp:
            return {'stamp': None}
        return {'stamp': stamp, 'age': self._master_freshness.check(stamp, self.get_clock().now().nanoseconds * 1e-9)}

    def _on_master_state(self, msg: JointState) -> None:
        try:
            self.mapping.on_master_lengths(time.monotonic(), lengths_from_joint_state(msg), **self._sample_time(msg))
        except StaleCommand as exc:
            self._late('master/actuators/state', exc)
            return
        except ValueError as exc:
            self._reject(f'master/actuators/state: {exc}')
            return
        if self.control == 'message' and self.mapping.config.mode == 'joint':
            self._control()

    def _late(self, topic: str, exc: StaleCommand) -> None:
        """A master sample older than master_timeout on arrival: dropped, not an error (a queue
        behind a stall delivers some); if no fresh one follows, the hold says why (MASTER_STALE)."""
        self.mapping.on_master_late(time.monotonic(), str(exc))
        self.get_logger().warning(f'{topic} sample dropped: {exc}', throttle_duration_sec=5.0)

    def _on_enable(self, msg: Bool) -> None:
        self.mapping.on_enable(time.monotonic(), msg.data)
        if not msg.data and self.mapping.engaged:
            self._watchdog()  # a released deadman holds at once

    def _on_slave_pose(self, msg: PoseStamped) -> None:
        if msg.header.frame_id != self.frame_id:
            self._reject(f'pose frame_id {msg.header.frame_id!r} is not {self.frame_id!r}')
            return
        try:
            position, quaternion = pose_from_msg(msg)
            self.mapping.on_slave_pose(position, quaternion, t=time.monotonic())
            self._support.support.on_slave_pose(quaternion)
        except ValueError as exc:
            self._reject(str(exc))
            return
        self._slave_stamp = stamp_to_seconds(msg.header.stamp)

    def _on_round_trip(self, msg: Float64) -> None:
        self.mapping.on_round_trip(time.monotonic(), msg.data)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        """The driver's lifecycle state, from its typed status: no engaging while inactive."""
        for status in msg.status:
            if source_node(status.name) == 'driver_node':
                try:
                    self.mapping.set_driver_active(DriverStatus.from_key_values(status.values).active)
                except ValueError as exc:
                    self._reject(f'driver status: {exc}')

    def _on_climb_status(self, msg: DiagnosticStatus) -> None:
        try:
            executing = ClimbStatus.from_key_values(msg.values).state is ClimbState.EXECUTING
        except ValueError as exc:
            self._reject(f'{CLIMB_STATUS}: {exc}')
            return
        self.mapping.set_climb_executing(executing)
        if executing and self.mapping.engaged:
            self._watchdog()

    def _reject(self, reason: str) -> None:
        self.get_logger().warning(f'input rejected: {reason}', throttle_duration_sec=1.0)
        self._publish_status(TeleopOutput(TeleopCode.INVALID, self.mapping.engaged, reason))

    # --- control -------------------------------------------------------------------------

    def _control(self) -> None:
        out = self.mapping.step(time.monotonic())
        self._stream.send(out, self.mapping.config.mode)
        self._publish_status(out)

    def _watchdog(self) -> None:
        blocked = self.mapping.check(time.monotonic())
        if blocked is not None:
            self._stream.brake(self.mapping.config.mode)   # a stop streams without master samples too
            self._publish_status(TeleopOutput(blocked[0], False, blocked[1]))
        else:
            self._stream.keep_up(self.mapping.command, self.mapping.config.mode, WATCHDOG_PERIOD)
            self._publish_status(self._output)

    def _slave_age_ms(self) -> float | None:
        if self._slave_stamp is None:
            return None
        return round(1e3 * (self.get_clock().now().nanoseconds * 1e-9 - self._slave_stamp), 2)

    def _publish_status(self, out: TeleopOutput, *, force: bool = False) -> None:
        """teleop/status and /diagnostics: at once when the code or engagement changes (or a new
        rejection reason comes), else at status_rate."""
        self._output = out
        now = time.monotonic()
        key = (out.code, out.engaged, out.detail if out.code == TeleopCode.INVALID else '')
        if not force and key == self._last_status and now - self._last_status_time < self._status_period:
            return
        self._last_status, self._last_status_time = key, now
        c = self.mapping.config
        level = _LEVELS.get(out.code, WARN)
        t = time.monotonic()
        values = TeleopStatus(code=out.code, engaged=out.engaged, mode=c.mode,
                              scale=c.translation_scale, rotation_mode=c.rotation_mode,
                              joint_scale=tuple(c.joint_scale), detail=out.detail,
                              round_trip_time=self.mapping.round_trip(t),
                              speed_factor=self.mapping.speed_factor(t),
                              feedback_force=self._feedback.force, feedback_limit=self._feedback.limit,
                              robot=self.robot_namespace, slave_age_ms=self._slave_age_ms(), **self._support.values(),
                              **{f'margin_{k}': v for k, v in out.margins.items()})
        status = DiagnosticStatus(level=level, name=self.get_name(), message=out.code.name,
                                  hardware_id=self.geometry.name)
        status.values = [KeyValue(key=k, value=v) for k, v in values.to_values().items()]
        self._status_pub.publish(status)
        self._diag.report(level, out.code.name, values)


def main(args=None) -> None:
    run_nodes([TeleopNode], args)
