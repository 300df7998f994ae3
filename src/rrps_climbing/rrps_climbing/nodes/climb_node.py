"""climb_node: executes climbing steps (the gait, a frame node's crossing or a route) on the robot
over ROS, with :class:`rrps_climbing.step_machine.ClimbStepMachine`.

Topics, services and the ``climb/step`` action: docs/usage.md ('The ROS interface') and
:mod:`rrps_interfaces.climb`; parameters: docs/parameters.md. Each step is planned and, with
``preview``, simulated in a worker process (:class:`rrps_climbing.step_worker.StepWorker`) so that
the node and the nodes composed with it keep their rate; the preview is anchored where the
odometry's ring_a stands. The step services reply from the node's action host
(:class:`rrps_climbing.climb_requests.StepRequests`), after the plan.
"""

from __future__ import annotations

import logging
import math

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TransformStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from rrps_climbing.climb_action import ClimbAction
from rrps_climbing.climb_planner import climb_planner, preview_config, step_machine
from rrps_climbing.climb_requests import StepRequests
from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.gait import GaitPlanner
from rrps_climbing.odometry_attitude import SupportPublisher, support_of_odometry
from rrps_climbing.route import ROUTES
from rrps_climbing.step_io import ClimbOutput, ClimbTarget, StepPlan
from rrps_climbing.step_worker import StepWorker
from rrps_description.geometry import load_robot
from rrps_description.loads import payload_from_parameters
from rrps_description.names import BASE_FRAME, ODOM_FRAME, RING_A_FRAME, RINGS, WORLD_FRAME, prefixed, ring_joint
from rrps_description.pose import QUATERNION_TOLERANCE, InvalidPose, Pose
from rrps_description.structures import STRUCTURES
from rrps_interfaces.climb import (
    CLIMB_PREVIEW,
    CLIMB_RESUME,
    CLIMB_STATUS,
    CLIMB_STEP,
    CLIMB_STEP_DOWN,
    CLIMB_STEP_UP,
    ODOMETRY,
    SUPPORT_POSE,
    ClimbState,
    ClimbStatus,
    odometry_topic,
)
from rrps_interfaces.driver import GRIPPERS_STATE, DriverStatus, gripper_service, gripper_states
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE, TARGET_RINGS
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_interfaces.teleop import TELEOP_STATUS, TeleopStatus
from rrps_kinematics.base_odometry import BaseOdometry
from rrps_runtime.action_host import ActionHost
from rrps_runtime.diagnostics import ERROR, OK, WARN, Diagnostics
from rrps_runtime.messages import (
    joint_state_msg,
    odometry_msg,
    pose_from_msg,
    pose_to_msg,
    stamp_to_seconds,
    transform_to_msg,
)
from rrps_runtime.parameter_schema import PAYLOAD, ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATCHED_QOS, LATEST_QOS, LINK_STATE_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_runtime.scheduling import scheduling_parameters
from rrps_runtime.supervision import CONTROL_RT_PRIORITY

__all__ = ['PARAMETERS', 'ClimbNode', 'main']

#: climb_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('climb_node', 'rrps_climbing', [
    ROBOT,
    Parameter('structure', 'pole', 'climbed structure, or a route: frame_route (several frame nodes, the frame '
              'climber), facade_corner (a facade round a corner, the facade climber)',
              choices=tuple(sorted(STRUCTURES)) + tuple(ROUTES)),
    Parameter('corner_deg', 20.0, 'facade_corner: the corner, positive outside', unit='deg', range=(-90.0, 90.0)),
    Parameter('route_bends_deg', (30.0, 30.0), "frame_route: each node's bend", unit='deg', item_type=float),
    Parameter('structure_length', 0.0, 'route length of the structure; 0 = its shipped length', unit='m',
              range=(0.0, 1000.0)),
    Parameter('structure_lean_deg', 0.0, 'the pole leans this much from the vertical about the world x axis',
              unit='deg', range=(-80.0, 80.0)),
    Parameter('start', -1.0, "route position of ring_a's gripper at start; negative = the lowest that fits",
              unit='m', range=(-1.0, 1000.0)),
    Parameter('step_length', 0.0, "length of one step; 0 = the planner's default for the robot", unit='m',
              range=(0.0, 10.0)),
    Parameter('auto_steps', 0, 'scripted climb: steps up to climb at start (0 = none)', range=(0, 10000)),
    Parameter('speed', 0.0, "cap on the moving ring's path speed; 0 = none: each motion is timed as fast as the "
              "legs' speed, acceleration, jerk and force limits and the holding capacity allow", unit='m/s',
              range=(0.0, 10.0)),
    Parameter('rate', 50.0, 'target_pose stream and state machine rate', unit='Hz', range=(1.0, 1000.0)),
    Parameter('position_tolerance', 0.001, 'arrival tolerance of the measured pose', unit='m',
              range=(1e-5, 0.1)),
    Parameter('orientation_tolerance', 0.01, 'arrival tolerance of the measured pose', unit='rad',
              range=(1e-5, 0.5)),
    Parameter('settle_timeout', 5.0, 'longest wait for the pose to arrive or a gripper to switch', unit='s',
              range=(0.1, 600.0)),
    Parameter('settle_time', 0.1, 'the pose must stay within tolerance this long before a gripper switches',
              unit='s', range=(0.0, 10.0)),
    Parameter('state_timeout', 0.2, 'pause when pose or grippers/state is older than this', unit='s',
              range=(0.01, 10.0)),
    Parameter('operator_timeout', 0.5,
              'pause when the operator station (its teleop/status, once seen) is silent this long', unit='s',
              range=(0.05, 60.0)),
    Parameter('use_extra_dof', True, 'use the extra ring DOF where the robot has one'),
    Parameter('junction_deg', 0.0, 'frame: cross its node, the member bent by this angle (0 = a straight '
              'splice, the inchworm gait); start defaults to the searched stance before the node', unit='deg',
              range=(0.0, 90.0)),
    Parameter('out_of_plane', False, "frame with junction_deg: the member bends normal to the column's web plane"),
    Parameter('preview', True, 'simulate each step on the dynamics before it executes; refuse it if it '
              'breaks a force or holding limit'),
    Parameter('gravity', (0.0, 0.0, -9.81), "the world's gravity in the structure's frame (the preview's)",
              unit='m/s^2', item_type=float),
    Parameter('preview_min_margin', 0.0, 'smallest holding margin a preview accepts', range=(-1.0, 1.0)),
    *PAYLOAD,
    *scheduling_parameters(CONTROL_RT_PRIORITY),
    Parameter('frame_prefix', '', "the odometry's frames are <frame_prefix>odom, <frame_prefix>base_link (as "
              "robot_state_publisher's frame_prefix: several robots in one domain)"),
    Parameter('odometry_length_stddev', 1e-4, "standard deviation of a measured leg length: the odometry's "
              'covariance', unit='m', range=(0.0, 0.1)),
])

LEVELS = {ClimbState.IDLE: OK, ClimbState.EXECUTING: OK, ClimbState.PAUSED: ERROR, ClimbState.FAILED: ERROR}


class ClimbNode(Node):
    """Executes climbing steps on the driver; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('climb_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        payload = payload_from_parameters(values)   # the plans' load check and the previews carry it
        self.geometry = load_robot(values['robot'])
        if payload is not None:
            self.geometry = self.geometry.with_(payload=payload)
        planner = climb_planner(self.geometry, values)
        self._log_crossing(planner)
        self.machine = step_machine(planner, values)
        self._worker = StepWorker(planner, self.machine.plan_request(self.machine.step_length, 1), self.geometry,
                                  preview_config(values))
        self._worker.when_ready(lambda s: self.get_logger().info(f'step planner ready: started in {s:.1f} s'))
        self._answer = None  # the Future of the step request whose reply waits for its plan
        self._pose_msg: PoseStamped | None = None
        self._odometry = None  # (world_T_a, world_T_b, stamp) not yet published
        self._gripper_call = None  # (GripperRequest, Future) awaiting the driver's answer

        self._tap = RecordingTap(self)
        self._target_pub = self._tap.create_publisher(PoseStamped, TARGET_POSE, COMMAND_QOS)
        # robots with the extra ring DOF: the rings are commanded, and measured for the odometry
        self._ring_joints = [ring_joint(r) for r in RINGS] if planner.dof else []
        self._ring_pub = (self._tap.create_publisher(JointState, TARGET_RINGS, COMMAND_QOS)
                          if self._ring_joints else None)
        if self._ring_joints:
            self.create_subscription(JointState, ACTUATORS_STATE, self._on_state, LATEST_QOS)
        self._status_pub = self.create_publisher(DiagnosticStatus, CLIMB_STATUS, STATE_QOS)
        self._preview_pub = self.create_publisher(DiagnosticStatus, CLIMB_PREVIEW, LATCHED_QOS)
        self._odo_pubs = {ring: self._tap.create_publisher(PoseStamped, odometry_topic(ring), STATE_QOS)
                          for ring in RINGS}
        self._support_pub = self.create_publisher(TransformStamped, SUPPORT_POSE, LATCHED_QOS)
        self._support_due = SupportPublisher()
        self._frames = (prefixed(values['frame_prefix'], ODOM_FRAME), prefixed(values['frame_prefix'], BASE_FRAME))
        self._base_odometry = BaseOdometry(self.geometry, values['odometry_length_stddev'], self.machine.config.period)
        self._base_pub = self._tap.create_publisher(Odometry, ODOMETRY, STATE_QOS)
        self.create_subscription(PoseStamped, POSE, self._on_pose, LATEST_QOS)
        self.create_subscription(JointState, GRIPPERS_STATE, self._on_grippers, STATE_QOS)
        # the operator station's sign of life: the newest sample counts; a reliable reader would
        # hold the later ones back until a lost one is resent (seconds on a lossy link)
        self.create_subscription(DiagnosticStatus, TELEOP_STATUS, self._on_teleop, LINK_STATE_QOS)
        self._gripper_clients = {ring: self.create_client(SetBool, gripper_service(ring)) for ring in RINGS}
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, STATE_QOS)
        self._diag = Diagnostics(self, 'climb', hardware_id=self.geometry.name)
        self._host = ActionHost(self)
        self._requests = StepRequests(self._host, {CLIMB_STEP_UP: (self.machine.step, (+1,)),
                                                   CLIMB_STEP_DOWN: (self.machine.step, (-1,)),
                                                   CLIMB_RESUME: (self.machine.resume, ())})
        self._action = None
        try:
            from rrps_msgs.action import ClimbStep  # optional: built by ./rrps (tools/rrps_msgs), not on PyPI
        except ImportError as exc:
            self.get_logger().info(f'the {CLIMB_STEP} action is off: rrps_msgs is not installed ({exc}); '
                                   'the step services serve')
        else:
            self._action = ClimbAction(self, ClimbStep, self._carry_out, self._host)
        self.create_timer(self.machine.config.period, self._on_tick)
        self.create_timer(0.5, lambda: self._publish_status(self.machine.report()))

    def _log_crossing(self, planner: GaitPlanner) -> None:
        """A frame-node crossing's search: its refusal (every step then refuses it) or its stance."""
        if not isinstance(planner, FrameNodePlanner):
            return
        if planner.refusal is not None:
            self.get_logger().error(f'frame node refused: {planner.refusal}')
        else:
            c = planner.crossing
            self.get_logger().info(f'{planner.title}: crossing from s={c.candidate.s_pre:.3f} m '
                                   f'(score {c.score:.3f}, {c.evaluated} candidates)')

    # --- the machine's state, for tests and tools ------------------------------------------------

    pose = property(lambda self: self.machine.pose, doc='the newest measured pose a_T_b used')
    watch = property(lambda self: self.machine.watch, doc='the input watch (climb_watch.InputWatch)')
    s_a = property(lambda self: self.machine.s_a, doc="route position [m] of ring_a's gripper at rest")
    measured_angles = property(lambda self: self.machine.measured_angles,
                               doc='the measured extra-DOF angles (theta_a, theta_b) [rad], or None')

    # --- inputs ---------------------------------------------------------------------------------

    def _on_pose(self, msg: PoseStamped) -> None:
        """Keep the newest measured pose; it is used at the node's rate (:meth:`_take_pose`)."""
        self._pose_msg = msg
        self.machine.pose_received()

    def _take_pose(self) -> None:
        """Give the machine the newest measured pose (if one came since it last got one)."""
        msg, self._pose_msg = self._pose_msg, None
        if msg is None or msg.header.frame_id != RING_A_FRAME:
            return
        try:
            pose = Pose(*pose_from_msg(msg), tolerance=QUATERNION_TOLERANCE)
        except InvalidPose as exc:
            self.get_logger().warning(f'pose ignored: {exc}', throttle_duration_sec=5.0)
            return
        out = self.machine.on_pose(pose)
        if out.odometry is not None:
            self._odometry = (*out.odometry, msg.header.stamp)
        self._carry_out(out)

    def _on_grippers(self, msg: JointState) -> None:
        state = gripper_states(msg.name, msg.position)
        if state is not None:
            self.machine.on_grippers(state)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        """The driver's lifecycle state, from its typed status."""
        for status in msg.status:
            if source_node(status.name) == 'driver_node':
                try:
                    self.machine.on_driver_active(DriverStatus.from_key_values(status.values).active)
                except ValueError as exc:
                    self.get_logger().warning(f'driver status ignored: {exc}', throttle_duration_sec=5.0)

    def _on_teleop(self, msg: DiagnosticStatus) -> None:
        try:
            engaged = TeleopStatus.from_key_values(msg.values).engaged
        except ValueError as exc:
            engaged = None
            self.get_logger().warning(f'{TELEOP_STATUS} ignored: {exc}', throttle_duration_sec=5.0)
        self.machine.on_teleop(engaged)  # the operator station is reachable

    def _on_state(self, msg: JointState) -> None:
        """The measured extra-DOF angles (robots that have them), for the odometry."""
        state = dict(zip(msg.name, msg.position))
        self.machine.on_ring_angles(*(state.get(name, math.nan) for name in self._ring_joints))

    def _take_requests(self) -> None:
        """Answer the step services' requests: at once, or, for one that plans, with its plan."""
        for call, args, answer in self._requests.take():
            self._take_pose()
            out = call(*args, self._now())
            self._carry_out(out)
            if out.plan is None:
                answer.set_result(out.reply)
            else:
                self._answer = answer

    def _answer_gripper(self) -> None:
        """Hand the driver's answer to the pending gripper request to the machine, once it came."""
        if self._gripper_call is None or not self._gripper_call[1].done():
            return
        request, future = self._gripper_call
        self._gripper_call = None
        result = future.result()
        self.machine.on_gripper_answer(request, result is not None and result.success,
                                       getattr(result, 'message', 'no reply'))

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _take_result(self) -> None:
        """Hand a finished plan to the machine (and its reply to the request), or publish a
        finished preview and hand it to the machine."""
        result = self._worker.result()
        if isinstance(result, StepPlan):
            out = self.machine.on_plan(result, self._now())
            self._carry_out(out)
            if self._answer is not None:
                self._answer.set_result(out.reply)
                self._answer = None
            return
        preview = result
        if preview is None:
            return
        msg = DiagnosticStatus(level=OK if preview.accepted else WARN, name=f'{self.get_name()}: preview',
                               message=preview.detail, hardware_id=self.geometry.name)
        msg.values = [KeyValue(key=k, value=v) for k, v in preview.to_values().items()]
        self._preview_pub.publish(msg)
        if self._action is not None:
            self._action.preview = preview
        self._carry_out(self.machine.on_preview(preview, self._now()))

    def _on_tick(self) -> None:
        self._take_result()
        self._take_requests()
        self._answer_gripper()
        self._take_pose()
        self._publish_odometry()
        self._carry_out(self.machine.tick(self._now()))
        if self._action is not None:
            self._action.tick(self._now())

    # --- outputs --------------------------------------------------------------------------------

    def _carry_out(self, out: ClimbOutput) -> None:
        """Log, command, request and report what the machine asked for."""
        for level, text in out.log:
            # one call site per severity: rclpy refuses a site whose severity changes
            if level >= logging.ERROR:
                self.get_logger().error(text)
            elif level >= logging.WARNING:
                self.get_logger().warning(text)
            else:
                self.get_logger().info(text)
        if out.target is not None:
            self._publish_target(out.target)
        if out.gripper is not None:
            request = SetBool.Request(data=out.gripper.close)
            self._gripper_call = (out.gripper, self._gripper_clients[out.gripper.ring].call_async(request))
        if out.plan is not None:
            self._worker.plan(out.plan)
        if out.preview is not None:
            odometry = self.machine.odometry  # the step previewed where the odometry stands
            self._worker.preview(out.preview, None if odometry is None else odometry.world_T_a,
                                 self.machine.config.period)
        if out.status is not None:
            self._publish_status(out.status)

    def _publish_target(self, target: ClimbTarget) -> None:
        """target_pose, and the extra-DOF angles on target_rings for robots that have them (the
        IK node sends them to the driver with the leg lengths)."""
        stamp = self.get_clock().now().to_msg()
        T = target.a_T_b
        self._target_pub.publish(pose_to_msg(T.position, T.quaternion_xyzw, frame_id=RING_A_FRAME, stamp=stamp))
        if self._ring_pub is not None:
            self._ring_pub.publish(joint_state_msg(stamp, target.ring_angles, names=self._ring_joints))

    def _publish_odometry(self) -> None:
        """The latest world poses of both rings and base_link's odometry, at the node's ``rate``
        (not at the pose rate)."""
        if self._odometry is None:
            return
        world_T_a, world_T_b, stamp = self._odometry
        self._odometry = None
        odom, base = self._frames
        for ring, T in (('ring_a', world_T_a), ('ring_b', world_T_b)):
            self._odo_pubs[ring].publish(pose_to_msg(T.position, T.quaternion_xyzw, frame_id=odom, stamp=stamp))
        support = support_of_odometry(world_T_a, world_T_b, self.machine.grippers)
        if support is not None and self._support_due.due(*support, self._now()):
            ring, T = support
            self._support_pub.publish(transform_to_msg(T.position, T.quaternion_xyzw, frame_id=WORLD_FRAME,
                                                       child_frame_id=ring, stamp=stamp))
        grippers = self.machine.grippers
        estimate = self._base_odometry.update(world_T_a, world_T_a.inverse() @ world_T_b,
                                              grippers is None or grippers['ring_a'], stamp_to_seconds(stamp))
        self._base_pub.publish(odometry_msg(estimate, stamp=stamp, frame_id=odom, child_frame_id=base))

    def _publish_status(self, status: ClimbStatus) -> None:
        level = WARN if status.state is ClimbState.IDLE and self.machine.plan_refused else LEVELS[status.state]
        msg = DiagnosticStatus(level=level, name=self.get_name(), message=status.state.value,
                               hardware_id=self.geometry.name)
        msg.values = [KeyValue(key=k, value=v) for k, v in status.to_values().items()]
        self._status_pub.publish(msg)
        self._diag.report(level, f'{status.state.value}: {status.detail}', status)

    def destroy_node(self) -> None:
        self._host.stop()   # never destroy a server while the host's thread waits on it
        if self._action is not None:
            self._action.close()
        self._host.close()
        self._worker.shutdown()
        super().destroy_node()


def main(args=None) -> None:
    run_nodes([ClimbNode], args)


if __name__ == '__main__':
    main()
