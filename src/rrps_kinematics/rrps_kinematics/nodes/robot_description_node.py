"""robot_description_node: the robot's URDF on ``robot_description`` and its joints on ``joint_states``.

The URDF (:func:`rrps_kinematics.urdf_joints.robot_urdf`) once, latched as robot_state_publisher
publishes it; every moving joint (:func:`rrps_kinematics.urdf_joints.joint_values`) from the IK of
``pose``, with its stamp, at most ``rate`` Hz and only for a new pose; the extra ring DOF from
``actuators/state``. See docs/recording.md, 'robot_description and RViz2'.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from rrps_description.geometry import load_robot
from rrps_description.names import RING_A_FRAME, RINGS, ring_joint
from rrps_description.pose import QUATERNION_TOLERANCE, Pose
from rrps_interfaces.kinematics import ACTUATORS_STATE, JOINT_STATES, POSE, ROBOT_DESCRIPTION
from rrps_kinematics.urdf_joints import joint_values, robot_urdf
from rrps_runtime.messages import pose_from_msg
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import LATCHED_QOS, LATEST_QOS, STATE_QOS

__all__ = ['RobotDescriptionNode', 'main']

#: robot_description_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('robot_description_node', 'rrps_kinematics', [
    ROBOT,
    Parameter('frame_id', RING_A_FRAME, 'frame_id a pose must have'),
    Parameter('rate', 30.0, 'largest joint_states rate', unit='Hz', range=(0.1, 1000.0)),
])


class RobotDescriptionNode(Node):
    """Publishes the URDF (latched) and the joint states of the measured pose."""

    def __init__(self, **kwargs):
        super().__init__('robot_description_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        self.frame_id = values['frame_id']
        self.urdf = robot_urdf(self.geometry)
        self.published = 0
        self.rejected = 0
        self._pose: PoseStamped | None = None  # the newest pose not yet published
        self._rings: dict[str, float] = {}
        self._ring_joints = {ring_joint(ring) for ring in RINGS if ring in self.geometry.extra_dof}
        self._description_pub = self.create_publisher(String, ROBOT_DESCRIPTION, LATCHED_QOS)
        self._description_pub.publish(String(data=self.urdf))
        self._joints_pub = self.create_publisher(JointState, JOINT_STATES, STATE_QOS)
        self.create_subscription(PoseStamped, POSE, self._on_pose, LATEST_QOS)
        if self._ring_joints:
            self.create_subscription(JointState, ACTUATORS_STATE, self._on_state, LATEST_QOS)
        self.create_timer(1.0 / values['rate'], self._publish)

    def _on_pose(self, msg: PoseStamped) -> None:
        self._pose = msg

    def _on_state(self, msg: JointState) -> None:
        """The extra ring DOF's measured angles (finite ones only)."""
        if len(msg.position) == len(msg.name):
            self._rings.update({name: float(value) for name, value in zip(msg.name, msg.position)
                                if name in self._ring_joints and math.isfinite(value)})

    def _publish(self) -> None:
        msg, self._pose = self._pose, None
        if msg is None:
            return
        try:
            if msg.header.frame_id != self.frame_id:
                raise ValueError(f'frame_id {msg.header.frame_id!r}, expected {self.frame_id!r}')
            a_T_b = Pose(*pose_from_msg(msg), tolerance=QUATERNION_TOLERANCE)
            values = joint_values(self.geometry, a_T_b, self._rings)
        except ValueError as exc:
            self.rejected += 1
            self.get_logger().warning(f'pose rejected, no joint_states for it: {exc}', throttle_duration_sec=5.0)
            return
        out = JointState()
        out.header.stamp = msg.header.stamp
        out.name = list(values)
        out.position = list(values.values())
        self._joints_pub.publish(out)
        self.published += 1


def main(args=None) -> None:
    run_nodes([RobotDescriptionNode], args)


if __name__ == '__main__':
    main()
