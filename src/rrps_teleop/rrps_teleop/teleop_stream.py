"""teleop_node's output: :class:`StreamOutput` publishes the guarded commands through
:class:`rrps_teleop.target_stream.TargetStream` (``jerk_limited``), the fastest stop while
disengaged until at rest, and :meth:`StreamOutput.keep_up` between master samples; each target
is stamped with its sample's ROS time. Every method runs on the node's executor thread."""

from __future__ import annotations

from rclpy.node import Node

from rrps_description.geometry import RobotGeometry
from rrps_runtime.messages import joint_state_msg, pose_to_msg
from rrps_teleop.mapping import TeleopOutput
from rrps_teleop.target_stream import TargetStream

__all__ = ['StreamOutput']


class StreamOutput:
    """Publishes ``node``'s targets (module docstring) on its ``publishers()`` (target_pose,
    actuators/command) in frame ``frame_id``."""

    def __init__(self, node: Node, geometry: RobotGeometry, *, jerk_limited: bool, frame_id: str, publishers):
        self.node, self.frame_id, self.publishers = node, frame_id, publishers
        self.stream = TargetStream(geometry) if jerk_limited else None
        self._following = False   # a command of the present engagement was streamed
        self._sent = 0.0          # when the last target was sent [s, ROS clock since the epoch]
        self._epoch = node.get_clock().now().nanoseconds   # the stream's times count from here

    def send(self, out: TeleopOutput, mode: str) -> None:
        """The target of one control step: towards ``out``'s command, or braking without one."""
        if not out.has_command:
            self.brake(mode)
            return
        now = self.node.get_clock().now()
        if self.stream is None:
            self._publish(now, mode, out.lengths, out.position, out.quaternion_xyzw)
            return
        if not self._following and not self.stream.moving:
            self.stream.reset()   # an engage from rest: the stream starts at the slave's own pose
        self._following = True
        self._publish(now, mode, *self.stream.follow(self._seconds(now), out.lengths, out.position,
                                                     out.quaternion_xyzw))

    def keep_up(self, command, mode: str, period: float) -> None:
        """Engaged, no control step for ``period`` [s]: the stream goes on towards the guarded
        ``command`` (None: none) until it rests there."""
        if self.stream is None or command is None or not self.stream.moving:
            return
        now = self.node.get_clock().now()
        if self._seconds(now) - self._sent < period:
            return
        self._publish(now, mode, *self.stream.follow(self._seconds(now), command.lengths, command.position,
                                                     command.quaternion))

    def brake(self, mode: str) -> None:
        """While disengaged: the stream's stop, until it is at rest."""
        self._following = False
        if self.stream is None or not self.stream.moving:
            return
        now = self.node.get_clock().now()
        sample = self.stream.stop(self._seconds(now))
        if sample is not None:
            self._publish(now, mode, *sample)

    def reset(self) -> None:
        """Another robot is driven: the stream ends (the old robot's driver brings its legs to
        rest on the last target)."""
        self._following = False
        if self.stream is not None:
            self.stream.reset()

    def _seconds(self, now) -> float:
        """``now`` (an rclpy Time) in s since the epoch (a double of 1.7e9 s would round to 0.2 us)."""
        return (now.nanoseconds - self._epoch) * 1e-9

    def _publish(self, now, mode: str, lengths, position, quaternion) -> None:
        self._sent = self._seconds(now)
        target_pub, command_pub = self.publishers()
        stamp = now.to_msg()
        if mode == 'cartesian':
            target_pub.publish(pose_to_msg(position, quaternion, frame_id=self.frame_id, stamp=stamp))
        else:
            command_pub.publish(joint_state_msg(stamp, lengths))
