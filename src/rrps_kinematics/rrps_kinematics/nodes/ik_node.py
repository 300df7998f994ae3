"""ik_node: target_pose (PoseStamped a_T_b, frame ring_a) -> actuators/command (leg lengths).

Every target is checked (:func:`rrps_kinematics.commands.validate_target`) and its age against
``timeout`` (:class:`rrps_runtime.freshness.CommandFreshness`); a rejected one is never acted on: the
last valid command stands and /diagnostics says why. ``limit_velocity`` caps each leg at ``max_speed``.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from rrps_description.geometry import load_robot
from rrps_description.names import LEG_NAMES, RING_A_FRAME, ring_joint
from rrps_description.pose import InvalidPose, Pose
from rrps_description.tool import TARGET_FRAMES, b_T_tool, ring_b_pose
from rrps_interfaces.kinematics import ACTUATORS_COMMAND, ACTUATORS_STATE, TARGET_POSE, TARGET_RINGS, IkStatus
from rrps_kinematics.commands import InvalidTarget, limit_velocity, pose_limits, validate_target
from rrps_runtime.diagnostics import OK, STALE, WARN, Diagnostics
from rrps_runtime.freshness import CommandAges, CommandFreshness, RejectedCommand
from rrps_runtime.messages import joint_state_msg, lengths_from_joint_state, pose_from_msg, stamp_to_seconds
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_runtime.scheduling import scheduling_parameters
from rrps_runtime.supervision import CONTROL_RT_PRIORITY

__all__ = ['IkNode', 'main']


#: ik_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('ik_node', 'rrps_kinematics', [
    ROBOT,
    Parameter('frame_id', RING_A_FRAME, 'frame_id a target_pose must have'),
    Parameter('timeout', 0.1, 'a target_pose whose stamp is older than this is rejected', unit='s',
              range=(1e-3, 60.0), dynamic=True),
    Parameter('target_frame', 'ring_b', "what a target_pose places: ring_b's origin, or the tool-centre point "
              '(robots with a tool)', choices=TARGET_FRAMES),
    Parameter('quaternion_tolerance', 1e-3, 'largest accepted | |q| - 1 | of a target quaternion',
              range=(0.0, 0.5), dynamic=True),
    Parameter('limit_velocity', False,
              'scale each command so no leg moves faster than max_speed since the previous one'),
    Parameter('max_speed', 0.0, "leg speed limit of limit_velocity; 0 = the robot's max_speed", unit='m/s',
              range=(0.0, 100.0)),
    *scheduling_parameters(CONTROL_RT_PRIORITY),
])


class IkNode(Node):
    """Inverse kinematics of the slave robot as a guarded command filter."""

    def __init__(self, **kwargs):
        super().__init__('ik_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        self.frame_id = values['frame_id']
        self.timeout = values['timeout']
        self.target_frame = values['target_frame']
        if self.target_frame == 'tool':
            b_T_tool(self.geometry)  # ValueError (exit 2) for a robot without a tool
        self.quaternion_tolerance = values['quaternion_tolerance']
        self.limit_velocity = values['limit_velocity']
        speed = values['max_speed']
        self.max_speed = speed if speed > 0.0 else self.geometry.max_speed
        if self.limit_velocity and math.isinf(self.max_speed):
            raise ValueError('limit_velocity needs a finite max_speed (the robot has none): set max_speed')
        # load the compiled guard now, not on the first target (which would then go stale)
        pose_limits(self.geometry, self.geometry.home_position, self.geometry.home_quaternion_xyzw)
        self.last_command: np.ndarray | None = None
        self._last_command_time: float | None = None
        self._measured: np.ndarray | None = None
        self.accepted = 0
        self.rejected = 0
        self.ages = CommandAges()
        self.freshness = CommandFreshness(self.timeout)
        self._status = (STALE, 'waiting for target_pose')
        self._margins: dict = {}
        self._tap = RecordingTap(self)
        self._pub = self._tap.create_publisher(JointState, ACTUATORS_COMMAND, COMMAND_QOS)
        self.create_subscription(PoseStamped, TARGET_POSE, self._on_target, COMMAND_QOS)
        self.ring_joints = [ring_joint(ring) for ring in ('ring_a', 'ring_b')
                            if ring in self.geometry.extra_dof]
        self._rings: tuple[float, list[float]] | None = None  # (receipt, angles)
        self._ring_freshness = CommandFreshness(self.timeout)
        if self.ring_joints:
            self.create_subscription(JointState, TARGET_RINGS, self._on_rings, COMMAND_QOS)
        if self.limit_velocity:
            self.create_subscription(JointState, ACTUATORS_STATE, self._on_state, STATE_QOS)
        self._diag = Diagnostics(self, 'inverse kinematics', hardware_id=self.geometry.name)
        self.create_timer(0.5, self._report)
        self.add_post_set_parameters_callback(self._apply_parameters)

    @property
    def status(self) -> tuple[bytes, str]:
        """(diagnostic level, message) of the node now."""
        return self._status

    @property
    def measured_lengths(self) -> np.ndarray | None:
        """The last actuators/state lengths [m] (with limit_velocity), or None."""
        return None if self._measured is None else self._measured.copy()

    def _apply_parameters(self, parameters) -> None:
        """``timeout`` and ``quaternion_tolerance`` take effect at run time (ranges checked by rclpy)."""
        for p in parameters:
            if p.name in ('timeout', 'quaternion_tolerance'):
                setattr(self, p.name, p.value)
            if p.name == 'timeout':
                self.freshness.timeout = p.value

    def _report(self) -> None:
        level, message = self._status
        now = self.get_clock().now().nanoseconds * 1e-9
        self._diag.report(level, message, IkStatus(
            accepted=self.accepted, rejected=self.rejected, robot=self.geometry.name,
            **self._margins, **self.ages.summary(now)))

    def _reject(self, reason: str, level=WARN) -> None:
        self.rejected += 1
        self._status = (level, f'target rejected, holding the last valid command: {reason}')
        self.get_logger().warning(self._status[1], throttle_duration_sec=1.0)
        self._report()

    def _on_rings(self, msg: JointState) -> None:
        """Extra-DOF ring angles to send with the next commands (robots that have the DOF)."""
        now_s = self.get_clock().now().nanoseconds * 1e-9
        try:
            angles = dict(zip(msg.name, msg.position))
            if len(angles) != len(msg.name) or len(msg.name) != len(msg.position) or \
                    set(angles) != set(self.ring_joints):
                raise RejectedCommand(f'{TARGET_RINGS}: joints {list(msg.name)}, expected '
                                      f'{self.ring_joints} with one angle each')
            for name, value in angles.items():
                dof = self.geometry.extra_dof[name.removesuffix('_rotation')]
                if not (math.isfinite(value) and dof.min_angle <= value <= dof.max_angle):
                    raise RejectedCommand(f'{TARGET_RINGS}: {name} {value!r} rad outside '
                                          f'[{dof.min_angle}, {dof.max_angle}]')
            self._ring_freshness.check(stamp_to_seconds(msg.header.stamp), now_s)
        except RejectedCommand as exc:
            self._reject(str(exc))
            return
        self._rings = (now_s, [float(angles[name]) for name in self.ring_joints])

    def _on_state(self, msg: JointState) -> None:
        try:
            self._measured = lengths_from_joint_state(msg)
        except ValueError:
            pass  # the driver reports its own faults; velocity limiting uses the last good state

    def _on_target(self, msg: PoseStamped) -> None:
        now = self.get_clock().now()
        now_s = now.nanoseconds * 1e-9
        stamp = stamp_to_seconds(msg.header.stamp)
        if stamp != 0.0:
            self.ages.add(now_s, now_s - stamp, stale=now_s - stamp > self.timeout)
        try:
            self.freshness.check(stamp, now_s)
            position, quaternion = pose_from_msg(msg)
            if self.target_frame == 'tool':  # a target for the tool tip: where ring_b must be
                a_T_b = ring_b_pose(self.geometry, Pose(position, quaternion,
                                                        tolerance=self.quaternion_tolerance))
                position, quaternion = a_T_b.position, a_T_b.quaternion_xyzw
            target = validate_target(self.geometry, position, quaternion, frame_id=msg.header.frame_id,
                                     expected_frame=self.frame_id,
                                     quaternion_tolerance=self.quaternion_tolerance)
        except (RejectedCommand, InvalidTarget, InvalidPose) as exc:
            self._reject(str(exc))
            return
        lengths = target.lengths
        if self.limit_velocity:
            base = self.last_command if self.last_command is not None else self._measured
            if base is None:
                self._reject('velocity limiting waits for the first actuators/state', level=STALE)
                return
            dt = 0.0 if self._last_command_time is None else min(now_s - self._last_command_time,
                                                                  self.timeout)
            lengths = limit_velocity(base, lengths, self.max_speed, max(dt, 0.0))
        self.last_command = lengths
        self._last_command_time = now_s
        self.accepted += 1
        rings = self._rings
        if rings is not None and now_s - rings[0] <= self.timeout:  # fresh ring angles go along
            self._pub.publish(joint_state_msg(msg.header.stamp, [*lengths, *rings[1]],
                                              names=[*LEG_NAMES, *self.ring_joints]))
        else:
            self._pub.publish(joint_state_msg(msg.header.stamp, lengths))
        self._margins = {f'min_{k}_margin': v for k, v in target.minimum.items()}
        if self._status[0] != OK:
            self._status = (OK, 'tracking target_pose')
            self._report()


def main(args=None) -> None:
    run_nodes([IkNode], args)


if __name__ == '__main__':
    main()
