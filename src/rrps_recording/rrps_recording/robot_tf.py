"""The robot's ``/tf`` as the recorder writes it: the transforms ``odom -> base_link`` (REP-105)
and the URDF's, fixed joints included (:func:`rrps_recording.markers.robot_frames`), from the
newest ``pose``, ``odometry/*`` and ``grippers/state`` messages (CDR as received), encoded as one
``tf2_msgs/msg/TFMessage`` (:func:`rrps_runtime.cdr.tf_message_cdr`: tf2_msgs is not needed). A
robot at rest keeps its transforms: they are computed again only when an input changes."""

from __future__ import annotations

import time

from geometry_msgs.msg import PoseStamped
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_interfaces.climb import odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE, gripper_states
from rrps_interfaces.kinematics import POSE
from rrps_interfaces.recording import TF
from rrps_recording.markers import robot_frames, world_pose_of_ring_a
from rrps_recording.storage.bag_metadata import TopicInfo
from rrps_recording.storage.qos import TF_QOS
from rrps_runtime.cdr import tf_message_cdr
from rrps_runtime.messages import pose_from_msg

__all__ = ['RobotTf', 'TF_TYPE', 'TF_TOPIC']

TF_TYPE = 'tf2_msgs/msg/TFMessage'
#: The /tf topic of the recording, as tf2's broadcasters offer it.
TF_TOPIC = TopicInfo(TF, TF_TYPE, (TF_QOS,))


class RobotTf:
    """The newest of the robot's state messages under ``namespace`` and the ``/tf`` they give."""

    def __init__(self, geometry: RobotGeometry, namespace: str):
        self.geometry = geometry
        ns = namespace.rstrip('/')
        #: {full topic name: what it is}: the inputs the recorder keeps (:attr:`latest`).
        self.inputs = {f'{ns}/{POSE}': POSE, f'{ns}/{GRIPPERS_STATE}': GRIPPERS_STATE,
                       f'{ns}/{odometry_topic("ring_a")}': 'ring_a',
                       f'{ns}/{odometry_topic("ring_b")}': 'ring_b'}
        self.latest: dict[str, bytes] = {}
        self._cache: tuple[tuple, list] | None = None  # (inputs, transforms)

    def message(self) -> tuple[int, bytes] | None:
        """(its stamp [ns]: now, the TFMessage (CDR)); None before the first pose. ValueError for
        a pose the robot cannot have."""
        pose_data = self.latest.get(next(k for k, v in self.inputs.items() if v == POSE))
        if pose_data is None:
            return None
        # The inputs without their stamps: each is a stamped message whose CDR starts with the
        # 4-byte encapsulation and header.stamp (8 bytes); a resting robot keeps the rest.
        inputs = tuple(None if d is None else d[12:]
                       for d in (self.latest.get(k) for k in self.inputs))
        if self._cache is not None and self._cache[0] == inputs:
            t = time.time_ns()  # a robot at rest: the same transforms, stamped now
            return t, tf_message_cdr(t, self._cache[1])
        a_T_b = Pose(*pose_from_msg(deserialize_message(pose_data, PoseStamped)))
        odometry = {ring: Pose(*pose_from_msg(deserialize_message(data, PoseStamped)))
                    for key, ring in self.inputs.items()
                    if ring in ('ring_a', 'ring_b') and (data := self.latest.get(key)) is not None}
        gripper_data = self.latest.get(next(k for k, v in self.inputs.items() if v == GRIPPERS_STATE))
        closed = None
        if gripper_data is not None:
            g = deserialize_message(gripper_data, JointState)
            closed = gripper_states(list(g.name), list(g.position))
        world_T_a = world_pose_of_ring_a(a_T_b, closed, odometry)
        transforms = robot_frames(self.geometry, a_T_b, world_T_a)
        self._cache = (inputs, transforms)
        t = time.time_ns()
        return t, tf_message_cdr(t, transforms)
