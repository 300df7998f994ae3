"""teleop_node's ``master/feedback`` (§3.1): :class:`MasterFeedback` publishes at ``feedback_rate``
the virtual fixture (:mod:`rrps_teleop.fixture`) at the guarded command, scaled to the master;
zero while disengaged. Every method runs on the node's executor thread."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node

from rrps_description.geometry import RobotGeometry
from rrps_interfaces.teleop import MASTER_FEEDBACK
from rrps_runtime.qos import COMMAND_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_teleop.fixture import FixtureConfig, fixture_wrench, master_wrench
from rrps_teleop.mapping import TeleopMapping

__all__ = ['MasterFeedback']


class MasterFeedback:
    """Publishes ``node``'s ``master/feedback`` through ``tap`` at ``rate`` [Hz] in frame
    ``frame_id`` (module docstring); ``force`` [N] and ``limit`` ('' when none) are the last
    wrench's force magnitude and its dominant limit."""

    def __init__(self, node: Node, tap: RecordingTap, mapping: TeleopMapping, geometry: RobotGeometry, *,
                 fixture: FixtureConfig, scale: float, frame_id: str, rate: float):
        self._node, self._mapping, self._geometry = node, mapping, geometry
        self.fixture, self.scale, self.frame_id = fixture, scale, frame_id
        self._pub = tap.create_publisher(WrenchStamped, MASTER_FEEDBACK, COMMAND_QOS)
        self.force, self.limit = 0.0, ''
        node.create_timer(1.0 / rate, self.publish)

    def publish(self) -> None:
        """The virtual fixture: the slave's limits near the guarded command, felt on the master
        (zero while disengaged)."""
        cmd = self._mapping.command if self._mapping.engaged else None
        force = torque = np.zeros(3)
        limit = ''
        if cmd is not None and self.scale > 0.0:
            wrench = fixture_wrench(self._geometry, cmd.position, cmd.quaternion, self.fixture)
            force, torque = master_wrench(wrench, translation_scale=self._mapping.config.translation_scale,
                                          force_scale=self.scale)
            limit = wrench.dominant or ''
        msg = WrenchStamped()
        msg.header.stamp = self._node.get_clock().now().to_msg()
        msg.header.frame_id = self.frame_id
        (msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z) = (float(v) for v in force)
        (msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z) = (float(v) for v in torque)
        self._pub.publish(msg)
        self.force, self.limit = float(np.linalg.norm(force)), limit
