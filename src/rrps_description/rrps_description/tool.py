"""The tool-centre-point frame of a robot that carries a tool on ring_b (Fig. 10):
``a_T_tool = a_T_b · b_T_tool``, so IK, teleoperation and the viewer can take targets for the tool
tip (:func:`tool_pose`, :func:`ring_b_pose`). Pure NumPy, no ROS import."""

from __future__ import annotations

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose

__all__ = ['TARGET_FRAMES', 'b_T_tool', 'tool_pose', 'ring_b_pose']

#: Frames a target may be given for: ring_b's origin, or the tool-centre point.
TARGET_FRAMES = ('ring_b', 'tool')


def b_T_tool(geometry: RobotGeometry) -> Pose:
    """The tool-centre-point frame in ring_b's frame; ValueError when there is no tool."""
    if geometry.tool is None:
        raise ValueError(f'robot {geometry.name!r} has no tool (its description has no tool section)')
    t = geometry.tool
    return Pose(t.position, t.quaternion_xyzw)


def tool_pose(geometry: RobotGeometry, a_T_b: Pose) -> Pose:
    """a_T_tool: the tool-centre point in ring_a's frame for ring_b at ``a_T_b``."""
    return a_T_b @ b_T_tool(geometry)


def ring_b_pose(geometry: RobotGeometry, a_T_tool: Pose) -> Pose:
    """a_T_b: where ring_b must be for the tool-centre point to be at ``a_T_tool``."""
    return a_T_tool @ b_T_tool(geometry).inverse()
