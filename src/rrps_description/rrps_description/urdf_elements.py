"""URDF's elements and their XML: links (visual and collision primitives, inertials), joints
(origin as URDF writes it, axis, limits; a joint's transform at a value, as a URDF parser computes
it) and the robot that holds them. Pure Python (XML through xml.etree), no ROS import; what the
robot's URDF contains is :mod:`rrps_description.urdf`'s."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cached_property
from typing import Mapping

import numpy as np

from rrps_description.pose import Pose
from rrps_description.rotations import normalize_quat, quat_multiply_xyzw, rpy_to_matrix

__all__ = ['Shape', 'Inertial', 'Link', 'Joint', 'JointFrames', 'RobotModel']

#: The materials the visuals name (RGBA).
_MATERIALS = {'ring': (0.47, 0.51, 0.59, 1.0), 'leg': (0.16, 0.67, 0.27, 1.0),
              'joint': (0.25, 0.25, 0.25, 1.0), 'gripper': (0.78, 0.78, 0.78, 1.0),
              'tool': (0.78, 0.35, 0.16, 1.0)}


@dataclass(frozen=True)
class Shape:
    """A visual or collision primitive in its link's frame: ``kind`` cylinder (radius, length
    along z), box (x, y, z) or sphere (radius,) [m], centred at ``xyz``."""

    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    material: str = 'ring'


@dataclass(frozen=True)
class Inertial:
    """Mass [kg], centre of mass [m] and inertia about it [kg m^2], in the link's frame."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class Link:
    """A URDF link: what it looks like, collides as, and weighs (None: massless)."""

    name: str
    visuals: tuple[Shape, ...] = ()
    collisions: tuple[Shape, ...] = ()
    inertial: Inertial | None = None


@dataclass(frozen=True)
class Joint:
    """A URDF joint: ``kind`` revolute, continuous, prismatic or fixed; ``origin`` the child's
    frame in the parent's at zero motion, as URDF writes it (``xyz``, ``rpy``); ``axis`` in that
    frame; limits [rad or m] for revolute and prismatic joints, effort [N] and velocity [m/s]."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    lower: float | None = None
    upper: float | None = None
    effort: float = 0.0
    velocity: float = 0.0

    @cached_property
    def origin(self) -> Pose:
        """The joint's origin as a Pose (from the written rpy, as a URDF parser reads it)."""
        return Pose.from_rotation(self.xyz, rpy_to_matrix(self.rpy))


@dataclass(frozen=True)
class JointFrames:
    """parent_T_child of joints: ``pairs`` (parent, child), ``positions`` (N, 3) [m] and unit
    ``quaternions`` (N, 4) (x, y, z, w; canonical sign, as :class:`Pose` keeps them)."""

    pairs: tuple[tuple[str, str], ...]
    positions: np.ndarray
    quaternions: np.ndarray


class _JointMotion:
    """A tree's joints as arrays: each joint's transform at its value is its origin, then its motion
    (a translation along the axis, or a rotation about it by the quaternion (axis sin, cos))."""

    def __init__(self, joints: tuple[Joint, ...]):
        self.names = [j.name for j in joints]
        self.pairs = [(j.parent, j.child) for j in joints]
        self.is_fixed = np.array([j.kind == 'fixed' for j in joints])
        self.prismatic = np.array([j.kind == 'prismatic' for j in joints])
        self.axes = np.array([j.axis for j in joints], dtype=float).reshape(-1, 3)
        self.origin_positions = np.array([j.origin.position for j in joints]).reshape(-1, 3)
        self.origin_quaternions = np.array([j.origin.quaternion_xyzw for j in joints]).reshape(-1, 4)
        self.origin_rotations = np.array([j.origin.rotation for j in joints]).reshape(-1, 3, 3)

    def frames(self, values: Mapping[str, float], fixed: bool) -> JointFrames:
        given = [name in values for name in self.names]
        take = np.flatnonzero(np.where(self.is_fixed, fixed, given))
        v = np.array([float(values[self.names[i]]) if given[i] else 0.0 for i in take])
        prismatic, axes = self.prismatic[take], self.axes[take]
        shift = np.where(prismatic, v, 0.0)[:, None] * axes
        half = 0.5 * np.where(prismatic, 0.0, v)  # a fixed joint's value is 0
        motion = np.concatenate([np.sin(half)[:, None] * axes, np.cos(half)[:, None]], axis=1)
        positions = self.origin_positions[take] + np.einsum('nij,nj->ni', self.origin_rotations[take], shift)
        quaternions = normalize_quat(quat_multiply_xyzw(self.origin_quaternions[take], motion))
        return JointFrames(tuple(self.pairs[i] for i in take), positions, quaternions)


@dataclass(frozen=True)
class RobotModel:
    """The URDF of a robot: links, joints (parents before children) and the notes written as
    XML comments at the top."""

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    notes: tuple[str, ...] = ()

    @property
    def moving_joints(self) -> tuple[str, ...]:
        """Names of the joints that move (every joint but the fixed ones), in tree order."""
        return tuple(j.name for j in self.joints if j.kind != 'fixed')

    @cached_property
    def _motion(self) -> _JointMotion:
        return _JointMotion(self.joints)

    def frames(self, values: Mapping[str, float], *, fixed: bool = True) -> JointFrames:
        """parent_T_child of every joint whose value is in ``values`` (and of the fixed joints unless
        ``fixed`` is False), in tree order, as robot_state_publisher computes them."""
        return self._motion.frames(values, fixed)

    def transforms(self, values: Mapping[str, float], *,
                   fixed: bool = True) -> list[tuple[str, str, Pose]]:
        """:meth:`frames` as (parent, child, parent_T_child)."""
        f = self.frames(values, fixed=fixed)
        return [(parent, child, Pose(p, q)) for (parent, child), p, q in zip(f.pairs, f.positions, f.quaternions)]

    def xml(self) -> str:
        """The URDF text."""
        robot = ET.Element('robot', name=self.name)
        for note in self.notes:
            robot.append(ET.Comment(f' {note} '))
        for name, rgba in _MATERIALS.items():
            ET.SubElement(ET.SubElement(robot, 'material', name=name), 'color', rgba=_numbers(rgba))
        for link in self.links:
            robot.append(_link_xml(link))
        for joint in self.joints:
            robot.append(_joint_xml(joint))
        ET.indent(robot)
        return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding='unicode') + '\n'


def _numbers(values) -> str:
    return ' '.join(repr(float(v)) for v in values)


def _shape_xml(parent: ET.Element, tag: str, shape: Shape) -> None:
    element = ET.SubElement(parent, tag)
    ET.SubElement(element, 'origin', xyz=_numbers(shape.xyz), rpy='0.0 0.0 0.0')
    geometry = ET.SubElement(element, 'geometry')
    if shape.kind == 'cylinder':
        ET.SubElement(geometry, 'cylinder', radius=repr(float(shape.size[0])), length=repr(float(shape.size[1])))
    elif shape.kind == 'box':
        ET.SubElement(geometry, 'box', size=_numbers(shape.size))
    else:
        ET.SubElement(geometry, 'sphere', radius=repr(float(shape.size[0])))
    if tag == 'visual':
        ET.SubElement(element, 'material', name=shape.material)


def _link_xml(link: Link) -> ET.Element:
    element = ET.Element('link', name=link.name)
    if link.inertial is not None:
        inertial = ET.SubElement(element, 'inertial')
        ET.SubElement(inertial, 'origin', xyz=_numbers(link.inertial.com), rpy='0.0 0.0 0.0')
        ET.SubElement(inertial, 'mass', value=repr(float(link.inertial.mass)))
        inertia = np.asarray(link.inertial.inertia, dtype=float)
        ET.SubElement(inertial, 'inertia', **{f'i{"xyz"[a]}{"xyz"[b]}': repr(float(inertia[a, b]))
                                             for a, b in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))})
    for shape in link.visuals:
        _shape_xml(element, 'visual', shape)
    for shape in link.collisions:
        _shape_xml(element, 'collision', shape)
    return element


def _joint_xml(joint: Joint) -> ET.Element:
    element = ET.Element('joint', name=joint.name, type=joint.kind)
    ET.SubElement(element, 'parent', link=joint.parent)
    ET.SubElement(element, 'child', link=joint.child)
    ET.SubElement(element, 'origin', xyz=_numbers(joint.xyz), rpy=_numbers(joint.rpy))
    if joint.kind != 'fixed':
        ET.SubElement(element, 'axis', xyz=_numbers(joint.axis))
    if joint.kind in ('revolute', 'prismatic'):
        ET.SubElement(element, 'limit', lower=repr(float(joint.lower)), upper=repr(float(joint.upper)),
                      effort=repr(float(joint.effort)), velocity=repr(float(joint.velocity)))
    return element
