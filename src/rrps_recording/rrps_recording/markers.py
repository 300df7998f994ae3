"""The robot for RViz2 and Foxglove: marker geometry and the transform tree. Pure, no rclpy.

:func:`robot_frames` gives the REP-105 tree as (parent, child, position, quaternion) and :func:`robot_transforms` as
(parent, child, Pose): ``odom`` -> ``base_link``, then the
URDF's (:mod:`rrps_description.urdf`) at the joint values of a_T_b (:mod:`rrps_kinematics.urdf_joints`), named as
robot_state_publisher names them, with ``frame_prefix`` for several robots on one /tf;
:func:`world_pose_of_ring_a` places ring_a from the gripping ring's odometry. The recorder's and markers_node's
/tf come from these two. :func:`robot_markers` describes the MarkerArray as :class:`MarkerSpec` values (what it
draws, in which frames and colours: docs/recording.md, 'Markers and /tf').
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.names import BASE_FRAME, ODOM_FRAME, RING_A_FRAME, prefixed
from rrps_description.pose import Pose
from rrps_kinematics.scene import robot_figure, world_ring_poses
from rrps_kinematics.urdf_joints import joint_values, robot_model

__all__ = ['MarkerSpec', 'robot_markers', 'robot_frames', 'robot_transforms', 'fixed_transforms',
           'structure_marker', 'ring_radius', 'world_pose_of_ring_a']

_CIRCLE_POINTS = 48
_RING_COLOUR = (0.47, 0.51, 0.59, 1.0)
_GHOST_COLOUR = (0.35, 0.67, 1.0, 0.5)
_STRUCTURE_COLOUR = (0.59, 0.43, 0.27, 1.0)
_GRIPPER_COLOURS = {True: (0.12, 0.12, 0.12, 1.0), False: (0.98, 0.86, 0.24, 1.0),
                    None: (0.78, 0.78, 0.78, 1.0)}


@dataclasses.dataclass(frozen=True)
class MarkerSpec:
    """One marker: ``kind`` is 'line_strip', 'line_list', 'cylinder' or 'triangle_list';
    ``points`` (N, 3) in ``frame`` after ``pose``; ``colours`` (N, 4) per point (RGBA 0..1) or
    None for the single ``colour``; ``scale`` as visualization_msgs/Marker uses it."""

    ns: str
    id: int
    kind: str
    frame: str
    colour: tuple[float, float, float, float]
    scale: tuple[float, float, float]
    pose: Pose = dataclasses.field(default_factory=Pose)
    points: np.ndarray | None = None
    colours: np.ndarray | None = None


def ring_radius(anchors: np.ndarray) -> float:
    """Mean radial distance of a ring's anchors [m]."""
    return float(np.mean(np.linalg.norm(np.asarray(anchors)[:, :2], axis=1)))


def _circle(radius: float) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, _CIRCLE_POINTS + 1)
    return np.stack([radius * np.cos(t), radius * np.sin(t), np.zeros_like(t)], axis=1)


def _named(transforms, frame_prefix: str) -> list[tuple[str, str, Pose]]:
    return [(prefixed(frame_prefix, parent), prefixed(frame_prefix, child), pose)
            for parent, child, pose in transforms]


def robot_frames(geometry: RobotGeometry, a_T_b: Pose, world_T_a: Pose | None = None,
                 ring_angles: dict[str, float] | None = None, *,
                 fixed: bool = True) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """The transform tree as (parent, child, position (3,), quaternion x, y, z, w (4,)): odom ->
    base_link (``world_T_a``, when given), then every joint of the URDF at a_T_b's joint values, as
    robot_state_publisher computes them; the fixed joints too unless ``fixed`` is False (they are
    :func:`fixed_transforms`), a ring's extra-DOF joint when ``ring_angles`` has its angle."""
    out = [] if world_T_a is None else [(ODOM_FRAME, BASE_FRAME, world_T_a.position, world_T_a.quaternion_xyzw)]
    f = robot_model(geometry).frames(joint_values(geometry, a_T_b, ring_angles), fixed=fixed)
    out += [(parent, child, p, q) for (parent, child), p, q in zip(f.pairs, f.positions, f.quaternions)]
    return out


def robot_transforms(geometry: RobotGeometry, a_T_b: Pose, world_T_a: Pose | None = None,
                     ring_angles: dict[str, float] | None = None, *,
                     fixed: bool = True, frame_prefix: str = '') -> list[tuple[str, str, Pose]]:
    """:func:`robot_frames` as (parent, child, parent_T_child), the frames named with ``frame_prefix``."""
    return _named([(parent, child, Pose(p, q)) for parent, child, p, q
                   in robot_frames(geometry, a_T_b, world_T_a, ring_angles, fixed=fixed)], frame_prefix)


def fixed_transforms(geometry: RobotGeometry, frame_prefix: str = '') -> list[tuple[str, str, Pose]]:
    """The URDF's fixed joints (parent, child, parent_T_child): robot_state_publisher's /tf_static."""
    return _named(robot_model(geometry).transforms({}), frame_prefix)


def world_pose_of_ring_a(a_T_b: Pose, grippers: dict | None,
                         odometry: dict[str, Pose | None]) -> Pose | None:
    """world_T_ring_a from the odometry ({ring: world_T_ring}) of the ring that grips: ring_b when
    ``grippers`` ({ring: closed}) says ring_a is open, else ring_a; None until it is known."""
    gripping = 'ring_b' if grippers is not None and not grippers['ring_a'] else 'ring_a'
    world_T_gripping = odometry.get(gripping)
    if world_T_gripping is None:
        return None
    world_T_a, _ = world_ring_poses(a_T_b=a_T_b, gripping=gripping,
                                    world_T_gripping=world_T_gripping)
    return world_T_a


def structure_marker(vertices: np.ndarray, faces: np.ndarray, frame_prefix: str = '') -> MarkerSpec:
    """The climbed member as a triangle list in ``odom`` (the world)."""
    points = np.asarray(vertices, dtype=float)[np.asarray(faces, dtype=int)].reshape(-1, 3)
    return MarkerSpec('structure', 0, 'triangle_list', prefixed(frame_prefix, ODOM_FRAME), _STRUCTURE_COLOUR,
                      (1.0, 1.0, 1.0), points=points)


def _robot_in(frame: str, ns_prefix: str, frame_T_a: Pose, geometry: RobotGeometry,
              a_T_b: Pose, figure, grippers: dict, target: Pose | None) -> list[MarkerSpec]:
    """The robot's markers in ``frame``; ``figure`` is its robot_figure in ring_a."""
    size = geometry.characteristic_length
    line = max(2.0 * geometry.leg_radius, 0.004 * size)
    r_a = ring_radius(geometry.ring_a_anchors)
    r_b = ring_radius(geometry.ring_b_anchors)
    frame_T_b = frame_T_a.compose(a_T_b)
    out = [
        MarkerSpec(f'{ns_prefix}rings', 0, 'line_strip', frame, _RING_COLOUR, (line, 0.0, 0.0),
                   points=frame_T_a.apply(_circle(r_a))),
        MarkerSpec(f'{ns_prefix}rings', 1, 'line_strip', frame, _RING_COLOUR, (line, 0.0, 0.0),
                   points=frame_T_b.apply(_circle(r_b))),
    ]
    colours = np.repeat(figure.leg_colours.astype(float) / 255.0, 2, axis=0)
    out.append(MarkerSpec(f'{ns_prefix}legs', 0, 'line_list', frame, (1.0, 1.0, 1.0, 1.0),
                          (line, 0.0, 0.0),
                          points=frame_T_a.apply(figure.leg_points.reshape(-1, 3)),
                          colours=np.hstack([colours, np.ones((12, 1))])))
    for k, (ring, pose, radius) in enumerate((('ring_a', frame_T_a, r_a),
                                               ('ring_b', frame_T_b, r_b))):
        closed = grippers.get(ring)
        out.append(MarkerSpec(f'{ns_prefix}grippers', k, 'cylinder', frame,
                              _GRIPPER_COLOURS[None if closed is None else bool(closed)],
                              (0.9 * radius, 0.9 * radius, 0.1 * radius), pose=pose))
    if target is not None:
        out.append(MarkerSpec(f'{ns_prefix}ghost', 0, 'line_strip', frame, _GHOST_COLOUR,
                              (line, 0.0, 0.0),
                              points=frame_T_a.compose(target).apply(_circle(r_b))))
    return out


def robot_markers(geometry: RobotGeometry, a_T_b: Pose, *, efforts=None,
                  grippers: dict | None = None, target: Pose | None = None,
                  world_T_a: Pose | None = None, frame_prefix: str = '') -> list[MarkerSpec]:
    """The robot's markers in ``ring_a`` and, when ``world_T_a`` is known, in ``odom`` (the
    frames named with ``frame_prefix``).

    ``grippers`` maps ring -> closed (True/False) or None (unknown); ``target`` is the
    commanded a_T_b (the ghost); ``efforts`` the legs' forces [N] (the force margin)."""
    grippers = grippers or {}
    figure = robot_figure(geometry, a_T_b=a_T_b, world_T_a=Pose(), efforts=efforts)
    out = _robot_in(prefixed(frame_prefix, RING_A_FRAME), '', Pose(), geometry, a_T_b, figure, grippers,
                    target)
    if world_T_a is not None:
        out += _robot_in(prefixed(frame_prefix, ODOM_FRAME), 'odom/', world_T_a, geometry, a_T_b, figure,
                         grippers, target)
    return out
