"""markers_node: the robot as visualization_msgs/MarkerArray, for RViz2 and Foxglove (issue 12).

Publishes ``robot/markers`` at ``rate`` Hz (:func:`rrps_teleop.recording.markers.robot_markers`):
in frame ``ring_a`` both rings, the six legs coloured by their worst margin (the viewer's
colours), the grippers (dark closed, yellow open, grey unknown) and the commanded target as a
ghost ring_b; in frame ``world``, once odometry places the robot, the same robot again
(namespaces ``world/...``) and the climbed structure (``structure``, every
``structure_period`` s). In RViz2: add a MarkerArray display on ``/rrps/robot/markers`` with
fixed frame ``ring_a`` (or ``world``). The recordings also carry ``/tf`` (recorder_node).

Subscribes (relative names): ``pose``, ``target_pose``, ``actuators/state`` (efforts),
``grippers/state``, ``odometry/ring_a|ring_b``; every subscription keeps only the newest
message, the markers are built at ``rate`` Hz.

    markers_node --ros-args -r __ns:=/rrps -p robot:=pole_climber
"""

from __future__ import annotations

import threading

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point, PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from rrps_kinematics.interfaces import ACTUATORS_STATE, POSE, TARGET_POSE
from rrps_kinematics.nodes.common import (
    COMMAND_QOS,
    LATEST_QOS,
    STATE_QOS,
    declare_parameter,
    declare_robot_parameter,
    pose_from_msg,
    run_nodes,
)
from rrps_kinematics.pose import Pose
from rrps_sim.interfaces import GRIPPERS_STATE, gripper_states

from ..interfaces import ROBOT_MARKERS, odometry_topic
from ..recording.markers import MarkerSpec, robot_markers, structure_marker
from ..viewer import world_ring_poses

__all__ = ['MarkersNode', 'main', 'marker_msg']

_KINDS = {'line_strip': Marker.LINE_STRIP, 'line_list': Marker.LINE_LIST,
          'cylinder': Marker.CYLINDER, 'triangle_list': Marker.TRIANGLE_LIST}


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


class MarkersNode(Node):
    """Publishes the robot's MarkerArray; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('markers_node', **kwargs)
        self.geometry = declare_robot_parameter(self)
        rate = declare_parameter(self, 'rate', 10.0, 'robot/markers rate [Hz]', min_value=0.1,
                                 max_value=100.0, read_only=True)
        structure = declare_parameter(self, 'structure', 'pole',
                                      'structure to draw in world (pole, palm_trunk, frame, '
                                      'facade; empty: none)', read_only=True)
        length = declare_parameter(self, 'structure_length', 3.0, 'drawn structure length [m]',
                                   min_value=0.5, max_value=100.0, read_only=True)
        self.structure_period = declare_parameter(
            self, 'structure_period', 1.0, 'the structure is re-sent this often [s]',
            min_value=0.1, max_value=60.0, read_only=True)
        self._structure = None
        if structure:  # static: its message is built once (thousands of points)
            from ..structures import make_structure
            vertices, faces = make_structure(structure, length).mesh()
            self._structure = marker_msg(structure_marker(vertices, faces),
                                         self.get_clock().now().to_msg())
        self._lock = threading.Lock()
        self._latest: dict[str, object] = {}
        self._structure_due = 0.0
        self.published = 0
        self._pub = self.create_publisher(MarkerArray, ROBOT_MARKERS, STATE_QOS)
        for topic, qos in ((POSE, LATEST_QOS), (TARGET_POSE, COMMAND_QOS),
                           (odometry_topic('ring_a'), LATEST_QOS),
                           (odometry_topic('ring_b'), LATEST_QOS)):
            self.create_subscription(PoseStamped, topic,
                                     lambda msg, topic=topic: self._store(topic, msg), qos)
        for topic in (ACTUATORS_STATE, GRIPPERS_STATE):
            self.create_subscription(JointState, topic,
                                     lambda msg, topic=topic: self._store(topic, msg), LATEST_QOS)
        self.create_timer(1.0 / rate, self._publish)

    def _store(self, topic: str, msg) -> None:
        with self._lock:
            self._latest[topic] = msg

    def markers(self) -> list[MarkerSpec]:
        """The markers of the newest messages (none before the first pose)."""
        with self._lock:
            latest = dict(self._latest)
        pose_msg = latest.get(POSE)
        if pose_msg is None:
            return []
        a_T_b = Pose(*pose_from_msg(pose_msg))
        grippers = None
        g = latest.get(GRIPPERS_STATE)
        if g is not None:
            grippers = gripper_states(list(g.name), list(g.position))
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
        gripping = 'ring_b' if grippers is not None and not grippers['ring_a'] else 'ring_a'
        world_T_a = None
        odom = latest.get(odometry_topic(gripping))
        if odom is not None:
            world_T_a, _ = world_ring_poses(a_T_b=a_T_b, gripping=gripping,
                                            world_T_gripping=Pose(*pose_from_msg(odom)))
        return robot_markers(self.geometry, a_T_b, efforts=efforts,
                             grippers=grippers or {}, target=target, world_T_a=world_T_a)

    def _publish(self) -> None:
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


def main(args=None) -> None:
    run_nodes([MarkersNode], args)


if __name__ == '__main__':
    main()
