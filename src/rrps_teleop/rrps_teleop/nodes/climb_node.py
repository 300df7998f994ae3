"""climb_node: executes inchworm gait steps (``rrps_teleop.climbing.gait``) on the robot over ROS.

Every phase of a checked plan is executed through the same paths as any other command: motions
stream ``target_pose`` (PoseStamped a_T_b, frame ring_a; so the IK node's guards apply) along
the planned path at ``speed``, and grippers switch through the driver's
``grippers/ring_a|ring_b/set`` services. Before a gripper switches, the measured ``pose`` (FK of
the measured lengths) must have arrived within ``position_tolerance`` / ``orientation_tolerance``
of the planned pose and stayed there ``settle_time``, and a gripper is only opened when
``grippers/state`` shows the other one closed (the interlock, on top of the planner's and the
driver's). Once an operator station has been seen, a gripper is also only opened after its
``teleop/status`` was heard again since the robot settled at the release pose: a link lost
before that holds the release (the step then pauses), so a gripper never opens on a link that
may already be gone for up to ``operator_timeout``.

Services ``climb/step_up``, ``climb/step_down`` (std_srvs/Trigger) plan and start one step;
``auto_steps`` > 0 climbs that many steps up once the robot's state is known (scripted runs).
A step is refused while ``teleop/status`` says engaged, while another executes, or when the
planner refuses it (the reply says which limit and where).

Liveness: a step **pauses** (state ``paused``, a typed ``PauseReason``) when ``pose`` or
``grippers/state`` is older than ``state_timeout`` (the driver or FK is gone), when the
operator station (its ``teleop/status``, once seen) has been silent for ``operator_timeout``
(the link is down), or when the driver leaves its active state. A paused step sends no target
and switches no gripper, so the robot holds where it is; it waits for the operator's
``climb/resume`` once the cause is gone (it never resumes by itself, and it is not aborted).
When the measured pose is off the gait (teleoperation moved ring_b), ring_b is first released,
brought back and re-gripped (``GaitPlanner.approach``, checked like any motion) before the step.

Publishes ``climb/status`` (DiagnosticStatus: message idle | executing | error; values step,
phase, structure, s_a, s_b, steps_done, detail) and the world odometry of both rings
``odometry/ring_a``, ``odometry/ring_b`` (PoseStamped, frame ``world``) chained from ``pose``
and ``grippers/state`` (``rrps_kinematics.odometry``), published at ``rate`` when a new pose came in.

``pose`` arrives at the driver's rate (500 Hz); the node keeps only the newest sample and uses
it at its own ``rate``, so a fast state stream costs it almost nothing and never queues up.
"""

from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from rrps_description.names import RING_A_FRAME, RINGS, WORLD_FRAME, ring_joint
from rrps_description.pose import QUATERNION_TOLERANCE, InvalidPose, Pose, pose_error
from rrps_description.structures import STRUCTURES, make_structure
from rrps_interfaces.climb import (
    CLIMB_RESUME,
    CLIMB_STATUS,
    CLIMB_STEP_DOWN,
    CLIMB_STEP_UP,
    ClimbState,
    ClimbStatus,
    PauseReason,
    PhaseAction,
    odometry_topic,
)
from rrps_interfaces.driver import GRIPPERS_STATE, DriverStatus, gripper_service, gripper_states
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE, TARGET_RINGS
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_interfaces.teleop import TELEOP_STATUS, TeleopStatus
from rrps_kinematics.odometry import RingOdometry
from rrps_runtime.diagnostics import ERROR, OK, WARN, Diagnostics
from rrps_runtime.messages import joint_state_msg, pose_from_msg, pose_to_msg
from rrps_runtime.parameters import declare_parameter, declare_robot_parameter
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATEST_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_teleop.climbing.climb_watch import InputWatch
from rrps_teleop.climbing.gait import GaitPlanner, PlanError
from rrps_teleop.climbing.phase_path import PhasePath

IDLE, EXECUTING, PAUSED, FAILED = (ClimbState.IDLE, ClimbState.EXECUTING, ClimbState.PAUSED,
                                   ClimbState.FAILED)


class ClimbNode(Node):
    """Executes climbing steps on the driver; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('climb_node', **kwargs)
        self.geometry = declare_robot_parameter(self)
        name = declare_parameter(self, 'structure', 'pole', f'climbed structure: {", ".join(sorted(STRUCTURES))}',
                                 read_only=True)
        length = declare_parameter(self, 'structure_length', 0.0,
                                   'route length of the structure [m]; 0 = its shipped length',
                                   min_value=0.0, max_value=1000.0, read_only=True)
        start = declare_parameter(self, 'start', -1.0,
                                  "route position of ring_a's gripper at start [m]; negative = the lowest that fits",
                                  min_value=-1.0, max_value=1000.0, read_only=True)
        step = declare_parameter(self, 'step_length', 0.0,
                                 "length of one step [m]; 0 = the planner's default for the robot",
                                 min_value=0.0, max_value=10.0, read_only=True)
        self.auto_steps = declare_parameter(self, 'auto_steps', 0,
                                            'scripted climb: steps up to climb at start (0 = none)',
                                            min_value=0, max_value=10000, read_only=True)
        self.speed = declare_parameter(self, 'speed', 0.02, 'speed of the moving gripper along its path [m/s]',
                                       min_value=1e-3, max_value=1.0, read_only=True)
        rate = declare_parameter(self, 'rate', 50.0, 'target_pose stream and state machine rate [Hz]',
                                 min_value=1.0, max_value=1000.0, read_only=True)
        self.position_tolerance = declare_parameter(
            self, 'position_tolerance', 0.001, 'arrival tolerance of the measured pose [m]',
            min_value=1e-5, max_value=0.1, read_only=True)
        self.orientation_tolerance = declare_parameter(
            self, 'orientation_tolerance', 0.01, 'arrival tolerance of the measured pose [rad]',
            min_value=1e-5, max_value=0.5, read_only=True)
        self.settle_timeout = declare_parameter(
            self, 'settle_timeout', 5.0, 'longest wait for the pose to arrive or a gripper to switch [s]',
            min_value=0.1, max_value=600.0, read_only=True)
        self.settle_time = declare_parameter(
            self, 'settle_time', 0.1, 'the pose must stay within tolerance this long before a gripper switches [s]',
            min_value=0.0, max_value=10.0, read_only=True)
        self.state_timeout = declare_parameter(
            self, 'state_timeout', 0.2, 'pause when pose or grippers/state is older than this [s]',
            min_value=0.01, max_value=10.0, read_only=True)
        self.operator_timeout = declare_parameter(
            self, 'operator_timeout', 0.5,
            'pause when the operator station (its teleop/status, once seen) is silent this long [s]',
            min_value=0.05, max_value=60.0, read_only=True)
        use_dof = declare_parameter(self, 'use_extra_dof', True,
                                    'use the extra ring DOF where the robot has one', read_only=True)
        if name not in STRUCTURES:
            raise ValueError(f'structure must be one of {sorted(STRUCTURES)}, got {name!r}')
        self.structure = make_structure(name, length or None)
        self.planner = GaitPlanner(self.geometry, self.structure, use_extra_dof=use_dof)
        self.step_length = step or self.planner.default_step
        sep = self.planner.sep_home
        s_a = max(0.0, -sep) if start < 0.0 else start
        if not (0.0 <= s_a and s_a + sep <= self.structure.length):
            raise ValueError(f'start {s_a} m: the robot does not fit on the {name} '
                             f'(route 0 .. {self.structure.length:.3f} m)')
        self.s_a, self.s_b, self.theta = s_a, s_a + sep, 0.0
        self.dt = 1.0 / rate

        self.mode = IDLE
        self.detail = 'waiting for pose and grippers/state'
        self._plan_refused = False
        self.pause_reason: PauseReason | None = None
        self.watch = InputWatch(state_timeout=self.state_timeout, operator_timeout=self.operator_timeout)
        self.driver_active: bool | None = None
        self.steps_done = 0
        self.pose: Pose | None = None
        self.grippers: dict[str, bool] | None = None
        self.teleop_engaged = False
        self.odometry: RingOdometry | None = None
        self._odometry_stamp = None
        self._phases: list = []
        self._index = 0
        self._stage = ''
        self._t = 0.0
        self._deadline = 0.0
        self._arrived_since: float | None = None
        self._settled = 0.0  # watch time when the robot settled at a gripper phase's pose
        self._future = None
        self._path: PhasePath | None = None
        self._auto_started = False
        self._last_status = None

        self._tap = RecordingTap(self)
        self._target_pub = self._tap.create_publisher(PoseStamped, TARGET_POSE, COMMAND_QOS)
        # robots with the extra ring DOF: the rings are commanded, and measured for the odometry
        self._ring_joints = [ring_joint(r) for r in ('ring_a', 'ring_b')] if self.planner.dof else []
        self._ring_pub = (self._tap.create_publisher(JointState, TARGET_RINGS, COMMAND_QOS)
                          if self._ring_joints else None)
        self.measured_angles: np.ndarray | None = None
        if self._ring_joints:
            self.create_subscription(JointState, ACTUATORS_STATE, self._on_state, LATEST_QOS)
        self._status_pub = self.create_publisher(DiagnosticStatus, CLIMB_STATUS, STATE_QOS)
        self._odo_pubs = {ring: self._tap.create_publisher(PoseStamped, odometry_topic(ring),
                                                           STATE_QOS)
                          for ring in RINGS}
        self._pose_msg: PoseStamped | None = None
        self.create_subscription(PoseStamped, POSE, self._on_pose, LATEST_QOS)
        self.create_subscription(JointState, GRIPPERS_STATE, self._on_grippers, STATE_QOS)
        self.create_subscription(DiagnosticStatus, TELEOP_STATUS, self._on_teleop, STATE_QOS)
        self._gripper_clients = {ring: self.create_client(SetBool, gripper_service(ring))
                                 for ring in RINGS}
        self.create_service(Trigger, CLIMB_STEP_UP, lambda req, res: self._on_step(res, +1))
        self.create_service(Trigger, CLIMB_STEP_DOWN, lambda req, res: self._on_step(res, -1))
        self.create_service(Trigger, CLIMB_RESUME, lambda req, res: self._on_resume(res))
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, STATE_QOS)
        self._diag = Diagnostics(self, 'climb')
        self.create_timer(self.dt, self._on_tick)
        self.create_timer(0.5, lambda: self._publish_status(force=True))

    # --- inputs ---------------------------------------------------------------------------------

    def _on_pose(self, msg: PoseStamped) -> None:
        """Keep the newest measured pose; it is used at the node's rate (:meth:`_take_pose`)."""
        self._pose_msg = msg
        self.watch.received('pose')

    def _take_pose(self) -> None:
        """The newest measured pose (if one came since the last tick) and the odometry it chains."""
        msg, self._pose_msg = self._pose_msg, None
        if msg is None:
            return
        if msg.header.frame_id != RING_A_FRAME:
            return
        try:
            self.pose = Pose(*pose_from_msg(msg), tolerance=QUATERNION_TOLERANCE)
        except InvalidPose as exc:
            self.get_logger().warning(f'pose ignored: {exc}', throttle_duration_sec=5.0)
            return
        if self.grippers is None:
            return
        ma, mb = self.planner.mounts(*self._thetas())
        if self.odometry is None:
            world_T_a = self.planner.world_rings(self.s_a, self.s_b, self.theta, self.theta)[0]
            self.odometry = RingOdometry(world_T_a, self.pose, a_T_grip=ma, b_T_grip=mb)
        elif self.grippers['ring_a'] or self.grippers['ring_b']:
            self.odometry.update(self.pose, self.grippers['ring_a'], self.grippers['ring_b'],
                                 a_T_grip=ma, b_T_grip=mb)
        else:
            self._fail('interlock: grippers/state shows both grippers open')
            return
        self._odometry_stamp = msg.header.stamp

    def _publish_odometry(self) -> None:
        """The latest world poses of both rings, at the node's ``rate`` (not at the pose rate)."""
        if self.odometry is None or self._odometry_stamp is None:
            return
        for ring, T in (('ring_a', self.odometry.world_T_a), ('ring_b', self.odometry.world_T_b)):
            self._odo_pubs[ring].publish(pose_to_msg(T.position, T.quaternion_xyzw,
                                                     frame_id=WORLD_FRAME, stamp=self._odometry_stamp))
        self._odometry_stamp = None

    def _on_grippers(self, msg: JointState) -> None:
        state = gripper_states(msg.name, msg.position)
        if state is not None:
            self.grippers = state
            self.watch.received('grippers/state')

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        """The driver's lifecycle state, from its typed status."""
        for status in msg.status:
            if source_node(status.name) == 'driver_node':
                try:
                    self.driver_active = DriverStatus.from_key_values(status.values).active
                except ValueError as exc:
                    self.get_logger().warning(f'driver status ignored: {exc}',
                                              throttle_duration_sec=5.0)

    def _on_teleop(self, msg: DiagnosticStatus) -> None:
        self.watch.received('teleop/status')  # the operator station is reachable
        try:
            self.teleop_engaged = TeleopStatus.from_key_values(msg.values).engaged
        except ValueError as exc:
            self.get_logger().warning(f'{TELEOP_STATUS} ignored: {exc}', throttle_duration_sec=5.0)

    def _on_state(self, msg: JointState) -> None:
        """The measured extra-DOF angles (robots that have them), for the odometry."""
        state = dict(zip(msg.name, msg.position))
        angles = [state.get(name, math.nan) for name in self._ring_joints]
        if all(math.isfinite(a) for a in angles):
            self.measured_angles = np.array(angles)

    def _thetas(self) -> tuple[float, float]:
        """The rings' extra-DOF angles (theta_a, theta_b) [rad]: measured by the driver where the
        robot has the DOF, else those of the plan."""
        if self.measured_angles is not None:
            return float(self.measured_angles[0]), float(self.measured_angles[1])
        if self.mode == EXECUTING and self._phases:
            ph = self._phases[min(self._index, len(self._phases) - 1)]
            return ph.theta_a, ph.theta_b
        return self.theta, self.theta

    # --- starting a climb -----------------------------------------------------------------------

    def _pause(self, reason: PauseReason) -> None:
        """Hold: no target, no gripper request until the operator resumes."""
        ph = self._phases[self._index]
        self.mode, self.pause_reason = PAUSED, reason
        self.detail = (f'paused at step {ph.step}, phase {ph.phase}: {reason.value} ({self.watch.ages()}); '
                       f'holding, grippers as they are; {CLIMB_RESUME} resumes')
        self.get_logger().error(self.detail)
        self._publish_status(force=True)

    def _on_resume(self, response):
        if self.mode is not PAUSED:
            response.success, response.message = False, f'refused: the climb is {self.mode.value}'
            return response
        reason = self.watch.hold_reason(driver_active=self.driver_active)
        if reason is not None:
            response.success, response.message = False, f'refused: {reason.value} ({self.watch.ages()})'
            return response
        self._take_pose()
        if self._stage == 'stream':
            expected, _ = self._path.at(self._t)
            dp, da = pose_error(self.pose, expected)
            if dp > 10 * self.position_tolerance or da > 10 * self.orientation_tolerance:
                response.success = False
                response.message = (f'refused: the robot is {dp * 1e3:.1f} mm / {math.degrees(da):.2f} '
                                    'deg off the paused path')
                return response
        self._deadline = self._now() + self.settle_timeout
        self.mode, self.pause_reason = EXECUTING, None
        ph = self._phases[self._index]
        self.detail = f'resumed at step {ph.step}, phase {ph.phase}'
        self._publish_status(force=True)
        response.success, response.message = True, self.detail
        return response

    def _on_step(self, response, direction: int):
        response.success, response.message = self.start_climb(direction * self.step_length, 1)
        return response

    def start_climb(self, distance: float, steps: int) -> tuple[bool, str]:
        """Plan and start a climb of ``distance`` [m] in ``steps``; (accepted, message)."""
        self._take_pose()
        if self.mode is EXECUTING:
            return False, 'refused: a climb is executing'
        if self.mode is PAUSED:
            return False, f'refused: a climb is paused ({self.pause_reason.value}): resume it'
        if self.mode == FAILED:
            return False, f'refused: climb_node is in error ({self.detail})'
        if self.teleop_engaged:
            return False, 'refused: teleoperation is engaged'
        if self.pose is None or self.grippers is None:
            return False, 'refused: no pose or grippers/state received yet'
        reason = self.watch.hold_reason(driver_active=self.driver_active)
        if reason is not None:
            return False, f'refused: {reason.value} ({self.watch.ages()})'
        try:
            plan = self.planner.plan(distance, steps, start=self.s_a,
                                     initial_separation=self.s_b - self.s_a, initial_theta=self.theta)
        except (PlanError, ValueError) as exc:
            self.detail, self._plan_refused = f'plan refused: {exc}', True
            self.get_logger().warning(self.detail)
            self._publish_status(force=True)
            return False, f'refused: {exc}'
        phases = plan.phases
        dp, da = pose_error(self.pose, phases[0].a_T_b)
        if dp > self.position_tolerance or da > self.orientation_tolerance:
            try:  # moved off the gait (teleoperation): ring_b first re-grips where the plan starts
                phases = self.planner.approach(self.pose, self.s_a, self.s_b, self.theta, self.theta) + phases
            except PlanError as exc:
                self.detail = f'plan refused: cannot bring ring_b back to the gait: {exc}'
                self._plan_refused = True
                self.get_logger().warning(self.detail)
                self._publish_status(force=True)
                return False, f'refused: {self.detail}'
        self._phases = phases
        self._index = 0
        self._enter_phase()
        self.mode = EXECUTING
        self.detail = f'{plan.steps} step(s) of {plan.step_length:.3f} m, {len(plan.phases)} phases'
        self._plan_refused = False
        self._publish_status(force=True)
        return True, f'started: {self.detail}'

    # --- execution ------------------------------------------------------------------------------

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _enter_phase(self) -> None:
        ph = self._phases[self._index]
        self._t = 0.0
        self._future = None
        self._arrived_since = None
        self._deadline = self._now() + self.settle_timeout
        if ph.action is PhaseAction.MOVE:
            self._path = PhasePath(ph.path, ph.ring_angles, speed=self.speed,
                                   characteristic_length=self.geometry.characteristic_length)
            self._stage = 'stream'
        else:
            self._stage = 'arrive'

    def _publish_target(self, T: Pose, angles: np.ndarray) -> None:
        """target_pose, and the extra-DOF angles on target_rings for robots that have them (the
        IK node sends them to the driver with the leg lengths)."""
        stamp = self.get_clock().now().to_msg()
        self._target_pub.publish(pose_to_msg(T.position, T.quaternion_xyzw, frame_id=RING_A_FRAME,
                                             stamp=stamp))
        if self._ring_pub is not None:
            self._ring_pub.publish(joint_state_msg(stamp, angles, names=self._ring_joints))

    def _arrived(self, T: Pose) -> bool:
        if self.pose is None:
            return False
        dp, da = pose_error(self.pose, T)
        return dp <= self.position_tolerance and da <= self.orientation_tolerance

    def _on_tick(self) -> None:
        self.watch.tick_started()
        try:
            self._tick()
        finally:
            self.watch.tick_ended()

    def _tick(self) -> None:
        self._take_pose()
        self._publish_odometry()
        if self.mode == IDLE and self.auto_steps > 0 and not self._auto_started \
                and self.pose is not None and self.grippers is not None:
            self._auto_started = True
            ok, message = self.start_climb(self.auto_steps * self.step_length, self.auto_steps)
            self.get_logger().info(f'scripted climb of {self.auto_steps} steps: {message}')
            return  # planning took this tick: the inputs are judged at the next one
        if self.mode is not EXECUTING:
            return
        reason = self.watch.hold_reason(driver_active=self.driver_active) if self.watch.judged() else None
        if reason is not None:
            self._pause(reason)
            return
        stages = {'stream': self._stream, 'arrive': self._arrive, 'gripper': self._switch_gripper}
        ph, now = self._phases[self._index], self._now()
        while self._stage in stages:
            if not stages[self._stage](ph, now):
                return
        if self._stage == 'done':
            self._next_phase(ph)

    # --- the stages of a phase: stream the path, arrive, switch the gripper, done ---------------
    # Each returns True when it passed on to the next stage within this tick, False when the
    # phase cannot go on this tick (still streaming, waiting, or failed).

    def _stream(self, ph, now: float) -> bool:
        """Stream the phase's path at the node's rate; then wait for the pose to arrive."""
        self._t += self.dt
        self._publish_target(*self._path.at(self._t))
        if self._t >= self._path.duration:
            self._stage = 'arrive'
            self._deadline = now + self.settle_timeout
        return False

    def _arrive(self, ph, now: float) -> bool:
        """Hold the phase's end pose until the measured pose stayed there ``settle_time``."""
        self._publish_target(ph.a_T_b, ph.ring_angles[-1])  # keep the command stream fresh
        if not self._arrived(ph.a_T_b):
            self._arrived_since = None
        elif self._arrived_since is None:
            self._arrived_since = now
        if self._arrived_since is not None and now - self._arrived_since >= self.settle_time:
            self._stage = ('gripper' if ph.action in (PhaseAction.RELEASE, PhaseAction.GRIP)
                           else 'done')
            self._deadline = now + self.settle_timeout
            self._settled = self.watch.now()
            return True
        if now > self._deadline:
            dp, da = pose_error(self.pose, ph.a_T_b) if self.pose is not None else (math.inf, math.inf)
            self._fail(f'step {ph.step}, phase {ph.phase}: the pose did not arrive within '
                       f'{self.settle_timeout:.1f} s (error {dp * 1000:.1f} mm, {math.degrees(da):.2f} deg)')
        return False

    def _switch_gripper(self, ph, now: float) -> bool:
        """Ask the driver to switch the phase's gripper (a ring opens only while the other is
        closed) and wait until ``grippers/state`` shows it switched."""
        self._publish_target(ph.a_T_b, ph.ring_angles[-1])
        ring = ph.ring
        close = ph.action is PhaseAction.GRIP
        if self._future is None:
            other = 'ring_b' if ring == 'ring_a' else 'ring_a'
            if not close and not self.grippers[other]:
                self._fail(f'step {ph.step}, phase {ph.phase}: interlock: {other} is not closed')
                return False
            if close or self.watch.operator_heard_since(self._settled):
                self._future = self._gripper_clients[ring].call_async(SetBool.Request(data=close))
            # else: open only once the operator station is heard since the robot settled
        elif self._future.done():
            result = self._future.result()
            if result is None or not result.success:
                self._fail(f'step {ph.step}, phase {ph.phase}: {ring} gripper refused: '
                           f'{getattr(result, "message", "no reply")}')
                return False
            if self.grippers[ring] == close:
                self._stage = 'done'
                return True
        if now > self._deadline:
            self._fail(f'step {ph.step}, phase {ph.phase}: {ring} gripper did not switch within '
                       f'{self.settle_timeout:.1f} s')
        return False

    def _next_phase(self, ph) -> None:
        """The phase is done: on to the next one, or the climb is over (idle)."""
        self.s_a, self.s_b = ph.s_a, ph.s_b
        self._index += 1
        if self._index >= len(self._phases):
            self.theta = ph.theta_a
            self.steps_done += max(p.step for p in self._phases)
            self.mode = IDLE
            self.detail = f'done: ring_a at s={self.s_a:.3f} m, ring_b at s={self.s_b:.3f} m'
            self._phases = []
            self._publish_status(force=True)
            return
        self._enter_phase()
        self._publish_status()

    def _fail(self, reason: str) -> None:
        self.mode = FAILED
        self.detail = reason
        self.get_logger().error(reason)
        self._publish_status(force=True)

    # --- status ---------------------------------------------------------------------------------

    def _publish_status(self, force: bool = False) -> None:
        ph = self._phases[self._index] if self.mode in (EXECUTING, PAUSED) and self._phases else None
        values = ClimbStatus(state=self.mode, pause_reason=self.pause_reason,
                             step=ph.step if ph else self.steps_done,
                             action=ph.action if ph else None, ring=ph.ring if ph else '',
                             structure=self.structure.name, s_a=self.s_a, s_b=self.s_b,
                             steps_done=self.steps_done, detail=self.detail)
        key = (self.mode, self.pause_reason, values.action, values.ring, values.step)
        if not force and key == self._last_status:
            return
        self._last_status = key
        level = {IDLE: OK, EXECUTING: OK, PAUSED: ERROR, FAILED: ERROR}[self.mode]
        if self.mode is IDLE and self._plan_refused:
            level = WARN
        status = DiagnosticStatus(level=level, name=self.get_name(), message=self.mode.value,
                                  hardware_id=self.geometry.name)
        status.values = [KeyValue(key=k, value=v) for k, v in values.to_values().items()]
        self._status_pub.publish(status)
        self._diag.report(level, f'{self.mode.value}: {self.detail}', values)


def main(args=None) -> None:
    run_nodes([ClimbNode], args)


if __name__ == '__main__':
    main()
