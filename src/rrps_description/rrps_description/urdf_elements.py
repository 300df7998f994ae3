"""URDF's elements and their XML: links (visual and collision primitives, inertials), joints
(origin as URDF writes it, axis, limits; a joint's transform at a value, as a URDF parser computes
it) and the robot that holds them. Pure Python (XML through xml.etree), no ROS import; what the
robot's URDF contains is :mod:`rrps_description.urdf`'s."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cached_property
from typing import Mapping

import numpy as np

from rrps_description.pose import Pose
from rrps_description.rotations import rpy_to_matrix

__all__ = ['Shape', 'Inertial', 'Link', 'Joint', 'RobotModel']

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

    def transform(self, value: float = 0.0) -> Pose:
        """parent_T_child at joint value ``value`` [rad or m]: the origin, then the motion (a
        translation along the axis, or a rotation about it by the quaternion (axis sin, cos))."""
        origin = self.origin
        if self.kind == 'fixed':
            return origin
        if self.kind == 'prismatic':
            return Pose(origin.position + origin.rotation @ (np.asarray(self.axis) * value),
                        origin.quaternion_xyzw)
        x1, y1, z1, w1 = (float(v) for v in origin.quaternion_xyzw)
        s, w2 = math.sin(0.5 * value), math.cos(0.5 * value)
        x2, y2, z2 = (s * v for v in self.axis)
        return Pose(origin.position, (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                                      w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2))


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

    def transforms(self, values: Mapping[str, float], *,
                   fixed: bool = True) -> list[tuple[str, str, Pose]]:
        """(parent, child, parent_T_child) of every joint whose value is in ``values`` (and of
        the fixed joints unless ``fixed`` is False), as robot_state_publisher computes them."""
        out = []
        for j in self.joints:
            if j.kind == 'fixed':
                if fixed:
                    out.append((j.parent, j.child, j.origin))
            elif j.name in values:
                out.append((j.parent, j.child, j.transform(float(values[j.name]))))
        return out

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
