"""markers_node: the robot as visualization_msgs/MarkerArray, and live /tf, for RViz2 and Foxglove.

``robot/markers`` (:func:`rrps_recording.markers.robot_markers`) at ``rate`` Hz while anything it shows changes,
at rest every ``structure_period`` s (for displays that join later). Live ``/tf`` at ``tf_rate`` Hz once a pose is
known, and the URDF's fixed joints once on latched ``/tf_static``, computed as the recorder computes its /tf
(:func:`rrps_recording.markers.robot_transforms`); without tf2_msgs it logs that live /tf is off. Every frame is
named with ``frame_prefix``. Subscribes, keeping the newest message only: ``pose``, ``target_pose``,
``actuators/state``, ``grippers/state``, ``odometry/ring_a|ring_b``. Frames, colours and RViz2:
docs/recording.md, 'Markers and /tf'.

    markers_node --ros-args -r __ns:=/rrps -p robot:=pole_climber -p tf_rate:=30.0
"""

from __future__ import annotations

import threading

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point, PoseStamped, TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from rrps_description.geometry import load_robot
from rrps_description.names import RINGS, ring_joint
from rrps_description.pose import Pose
from rrps_interfaces.climb import odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE, gripper_states
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE
from rrps_interfaces.recording import ROBOT_MARKERS, TF, TF_STATIC
from rrps_recording.markers import (
    MarkerSpec,
    fixed_transforms,
    robot_markers,
    robot_transforms,
    structure_marker,
    world_pose_of_ring_a,
)
from rrps_recording.storage.qos import TF_QOS
from rrps_runtime.messages import pose_from_msg
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATCHED_QOS, LATEST_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap

__all__ = ['MarkersNode', 'main', 'marker_msg', 'transform_msgs']

#: The live /tf publisher's QoS: tf2_ros' TransformBroadcaster's (TF_QOS).
_TF_PUBLISHER_QOS = QoSProfile(history=HistoryPolicy(TF_QOS.history), depth=TF_QOS.depth,
                               reliability=ReliabilityPolicy(TF_QOS.reliability),
                               durability=DurabilityPolicy(TF_QOS.durability))

_KINDS = {'line_strip': Marker.LINE_STRIP, 'line_list': Marker.LINE_LIST,
          'cylinder': Marker.CYLINDER, 'triangle_list': Marker.TRIANGLE_LIST}

#: markers_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('markers_node', 'rrps_recording', [
    ROBOT,
    Parameter('rate', 10.0, 'robot/markers rate', unit='Hz', range=(0.1, 100.0)),
    Parameter('structure', 'pole', 'structure to draw in odom (pole, palm_trunk, frame, facade; empty: none)'),
    Parameter('structure_length', 3.0, 'drawn structure length', unit='m', range=(0.5, 100.0)),
    Parameter('structure_lean_deg', 0.0, 'the drawn pole leans this much from the vertical about the world x axis',
              unit='deg', range=(-80.0, 80.0)),
    Parameter('junction_deg', 0.0, 'frame: its member bent by this angle at the node', unit='deg', range=(0.0, 90.0)),
    Parameter('out_of_plane', False, "frame: the member bends normal to the column's web plane"),
    Parameter('structure_period', 1.0, 'the structure is re-sent this often', unit='s', range=(0.1, 60.0)),
    Parameter('tf_rate', 30.0, 'live /tf rate (needs tf2_msgs); 0 = off', unit='Hz', range=(0.0, 1000.0)),
    Parameter('frame_prefix', '', "every frame is <frame_prefix><name> (as robot_state_publisher's frame_prefix: "
              'several robots in one domain)'),
])


def marker_msg(spec: MarkerSpec, stamp) -> Marker:
    """A visualization_msgs/Marker from a MarkerSpec (plain floats: no numpy in the message)."""
    m = Marker()
    m.header.frame_id = spec.frame
    m.header.stamp = stamp
    m.ns, m.id, m.type, m.action = spec.ns, int(spec.id), _KINDS[spec.kind], Marker.ADD
    p, q = spec.pose.position, spec.pose.quaternion_xyzw
    m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in p)
    (m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z,
     m.pose.orientation.w) = (float(v) for v in q)
    m.scale.x, m.scale.y, m.scale.z = (float(v) for v in spec.scale)
    m.color = ColorRGBA(r=float(spec.colour[0]), g=float(spec.colour[1]),
                        b=float(spec.colour[2]), a=float(spec.colour[3]))
    if spec.points is not None:
        m.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in spec.points]
    if spec.colours is not None:
        m.colors = [ColorRGBA(r=float(c[0]), g=float(c[1]), b=float(c[2]), a=float(c[3]))
                    for c in spec.colours]
    m.lifetime = Duration(sec=0, nanosec=0)
    m.frame_locked = True
    return m


def transform_msgs(transforms, stamp) -> list[TransformStamped]:
    """geometry_msgs/TransformStamped messages from (parent, child, parent_T_child) triples."""
    out = []
    for parent, child, pose in transforms:
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
        tr, rot = t.transform.translation, t.transform.rotation
        tr.x, tr.y, tr.z = (float(v) for v in pose.position)
        rot.x, rot.y, rot.z, rot.w = (float(v) for v in pose.quaternion_xyzw)
        out.append(t)
    return out


class MarkersNode(Node):
    """Publishes the robot's MarkerArray; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('markers_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        self._ring_joints = {ring_joint(ring) for ring in RINGS if ring in self.geometry.extra_dof}
        structure = values['structure']
        self.structure_period = values['structure_period']
        tf_rate = values['tf_rate']
        self.frame_prefix = values['frame_prefix']
        self._structure = None
        if structure:  # static: its message is built once (thousands of points)
            from rrps_description.structures import structure_from_parameters
            vertices, faces = structure_from_parameters(values).mesh()
            self._structure = marker_msg(structure_marker(vertices, faces, self.frame_prefix),
                                         self.get_clock().now().to_msg())
        self._lock = threading.Lock()
        self._latest: dict[str, object] = {}
        self._structure_due = 0.0
        self._last_inputs: tuple | None = None
        self._resend_due = 0.0
        self.published = 0
        self._tap = RecordingTap(self)
        self._pub = self._tap.create_publisher(MarkerArray, ROBOT_MARKERS, STATE_QOS)
        for topic, qos in ((POSE, LATEST_QOS), (TARGET_POSE, COMMAND_QOS),
                           (odometry_topic('ring_a'), LATEST_QOS),
                           (odometry_topic('ring_b'), LATEST_QOS)):
            self.create_subscription(PoseStamped, topic,
                                     lambda msg, topic=topic: self._store(topic, msg), qos)
        for topic in (ACTUATORS_STATE, GRIPPERS_STATE):
            self.create_subscription(JointState, topic,
                                     lambda msg, topic=topic: self._store(topic, msg), LATEST_QOS)
        self.create_timer(1.0 / values['rate'], self._publish)
        self.tf_published = 0
        self._tf_pub = None
        self._tf_cache: tuple[tuple, list] | None = None  # (inputs, transforms)
        if tf_rate > 0.0:
            try:
                from tf2_msgs.msg import TFMessage  # optional: built by ./rrps, not on PyPI
            except ImportError as exc:
                self.get_logger().info(f'live /tf is off: tf2_msgs is not installed ({exc}); '
                                       './rrps builds it when cmake and a C compiler are there')
            else:
                self._tf_type = TFMessage
                self._tf_pub = self.create_publisher(TFMessage, TF, _TF_PUBLISHER_QOS)
                self._tf_static_pub = self.create_publisher(TFMessage, TF_STATIC, LATCHED_QOS)
                self._tf_static_pub.publish(TFMessage(transforms=transform_msgs(
                    fixed_transforms(self.geometry, self.frame_prefix), self.get_clock().now().to_msg())))
                self.create_timer(1.0 / tf_rate, self._publish_tf)

    def _store(self, topic: str, msg) -> None:
        with self._lock:
            self._latest[topic] = msg

    def _robot(self, latest: dict) -> tuple[Pose, dict | None, Pose | None]:
        """(a_T_b, grippers {ring: closed} or None, world_T_a or None) of the newest messages."""
        a_T_b = Pose(*pose_from_msg(latest[POSE]))
        grippers = None
        g = latest.get(GRIPPERS_STATE)
        if g is not None:
            grippers = gripper_states(list(g.name), list(g.position))
        odometry = {ring: Pose(*pose_from_msg(msg)) for ring in ('ring_a', 'ring_b')
                    if (msg := latest.get(odometry_topic(ring))) is not None}
        return a_T_b, grippers, world_pose_of_ring_a(a_T_b, grippers, odometry)

    def markers(self) -> list[MarkerSpec]:
        """The markers of the newest messages (none before the first pose)."""
        with self._lock:
            latest = dict(self._latest)
        if latest.get(POSE) is None:
            return []
        a_T_b, grippers, world_T_a = self._robot(latest)
        efforts = None
        state = latest.get(ACTUATORS_STATE)
        if state is not None and len(state.effort) == len(state.name) and state.name:
            index = {n: i for i, n in enumerate(state.name)}
            if all(f'leg_{i}' in index for i in range(1, 7)):
                efforts = np.array([state.effort[index[f'leg_{i}']] for i in range(1, 7)])
                if not np.all(np.isfinite(efforts)):
                    efforts = None
        target = None
        if latest.get(TARGET_POSE) is not None:
            try:
                target = Pose(*pose_from_msg(latest[TARGET_POSE]))
            except ValueError:
                target = None
        return robot_markers(self.geometry, a_T_b, efforts=efforts,
                             grippers=grippers or {}, target=target, world_T_a=world_T_a,
                             frame_prefix=self.frame_prefix)

    def transforms(self) -> list:
        """The /tf transforms (parent, child, Pose) of the newest messages (none before a pose):
        the moving ones (the fixed ones are on /tf_static)."""
        with self._lock:
            latest = dict(self._latest)
        if latest.get(POSE) is None:
            return []
        a_T_b, _, world_T_a = self._robot(latest)
        state = latest.get(ACTUATORS_STATE)
        rings = {}
        if state is not None and len(state.position) == len(state.name):
            rings = {name: value for name, value in zip(state.name, state.position)
                     if name in self._ring_joints and np.isfinite(value)}
        return robot_transforms(self.geometry, a_T_b, world_T_a, rings, fixed=False, frame_prefix=self.frame_prefix)

    def _inputs(self) -> tuple:
        """What the markers are drawn from (the newest messages' values, not their stamps)."""
        with self._lock:
            latest = dict(self._latest)

        def pose(msg):
            if msg is None:
                return None
            p, o = msg.pose.position, msg.pose.orientation
            return (p.x, p.y, p.z, o.x, o.y, o.z, o.w)
        state, grippers = latest.get(ACTUATORS_STATE), latest.get(GRIPPERS_STATE)
        return (pose(latest.get(POSE)), pose(latest.get(TARGET_POSE)),
                pose(latest.get(odometry_topic('ring_a'))), pose(latest.get(odometry_topic('ring_b'))),
                None if state is None else (tuple(state.effort), tuple(
                    v for n, v in zip(state.name, state.position) if n in self._ring_joints)),
                None if grippers is None else tuple(grippers.position))

    def _publish(self) -> None:
        t = self.get_clock().now().nanoseconds * 1e-9
        inputs = self._inputs()
        if inputs == self._last_inputs and t < self._resend_due:
            return  # a robot at rest: nothing new to draw (re-sent each structure_period)
        self._last_inputs, self._resend_due = inputs, t + self.structure_period
        try:
            specs = self.markers()
        except ValueError as exc:
            self.get_logger().warning(f'no markers for this pose: {exc}',
                                      throttle_duration_sec=5.0)
            return
        now = self.get_clock().now()
        t = now.nanoseconds * 1e-9
        if not specs:
            return
        stamp = now.to_msg()
        markers = [marker_msg(s, stamp) for s in specs]
        if self._structure is not None and t >= self._structure_due:
            self._structure.header.stamp = stamp
            markers.append(self._structure)
            self._structure_due = t + self.structure_period
        self._pub.publish(MarkerArray(markers=markers))
        self.published += 1

    def _publish_tf(self) -> None:
        inputs = self._inputs()
        if self._tf_cache is not None and self._tf_cache[0] == inputs:
            transforms = self._tf_cache[1]  # a robot at rest: the same transforms, stamped now
        else:
            try:
                transforms = self.transforms()
            except ValueError as exc:
                self.get_logger().warning(f'no /tf for this pose: {exc}', throttle_duration_sec=5.0)
                return
            self._tf_cache = (inputs, transforms)
        if transforms:
            stamp = self.get_clock().now().to_msg()
            self._tf_pub.publish(self._tf_type(transforms=transform_msgs(transforms, stamp)))
            self.tf_published += 1


def main(args=None) -> None:
    run_nodes([MarkersNode], args)


if __name__ == '__main__':
    main()
