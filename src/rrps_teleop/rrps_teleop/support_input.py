"""teleop_node's inputs for its load guards' support: the driven robot's ``grippers/state`` and
``odometry/support`` handed to :class:`rrps_teleop.load_support.LoadSupport`, starting from
``support`` and ``world_q_support`` (again at a robot switch). Runs on the executor thread."""

from __future__ import annotations

import time

from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from rrps_description.world import Support
from rrps_interfaces.climb import SUPPORT_POSE
from rrps_interfaces.driver import GRIPPERS_STATE, gripper_states
from rrps_interfaces.link import robot_topic
from rrps_runtime.messages import transform_from_msg
from rrps_runtime.qos import LATCHED_QOS, LINK_EVENT_QOS, LINK_STATE_QOS, STATE_QOS
from rrps_teleop.load_guard import LoadGuard
from rrps_teleop.load_support import LoadSupport

__all__ = ['SupportInput']


class SupportInput:
    """Keeps ``guard`` on the driven robot's supporting ring and its odometry's attitude."""

    def __init__(self, node: Node, guard: LoadGuard, start: Support):
        self._node, self._guard, self._start = node, guard, start
        self.support = LoadSupport(guard)

    def attach(self, namespace: str, source: str) -> list:
        """Subscribe the robot in ``namespace`` (read from ``source``: 'direct' or 'link'),
        starting again from the parameters' support; the subscriptions."""
        self._guard.set_support(self._start)
        self.support = LoadSupport(self._guard)
        link = source == 'link'
        node = self._node
        return [node.create_subscription(JointState, robot_topic(GRIPPERS_STATE, namespace, source),
                                         self._on_grippers, LINK_EVENT_QOS if link else STATE_QOS),
                node.create_subscription(TransformStamped, robot_topic(SUPPORT_POSE, namespace, source),
                                         self._on_support, LINK_STATE_QOS if link else LATCHED_QOS)]

    def _on_grippers(self, msg: JointState) -> None:
        closed = gripper_states(msg.name, msg.position)
        if closed is not None:
            self._changed(self.support.on_grippers(closed, time.monotonic()))

    def _on_support(self, msg: TransformStamped) -> None:
        _, q = transform_from_msg(msg)
        if not self.support.on_odometry(msg.header.frame_id, msg.child_frame_id, q, time.monotonic()):
            self._node.get_logger().warning(f'{SUPPORT_POSE} rejected, the load guards keep their support: '
                                            f'{self.support.follower.rejection}', throttle_duration_sec=5.0)

    def _changed(self, support: Support | None) -> None:
        if support is not None:
            self._node.get_logger().info(f'load guards: {support.ring} supports the robot now')

    def values(self) -> dict:
        """The TeleopStatus values of the support in use."""
        report = self.support.report(time.monotonic())
        return {'support_ring': report.support.ring, 'support_source': report.source}
