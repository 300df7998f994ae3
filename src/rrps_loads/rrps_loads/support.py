"""The world's loads where the kinematics computes: gravity and the tool wrench in ring_a's frame,
for a supporting ring turned by ``world_q_support``; with ring_b supporting, g_a turns with a_T_b.
A tool wrench in the tool frame turns with ring_b, one in the world frame does not.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_description.world import Support

__all__ = ['Support', 'WorldLoads', 'support_of', 'tool_wrench_in_support', 'world_loads']


def support_of(support='ring_a', world_q_support=None, gravity=None) -> Support:
    """A :class:`Support` as given (an instance is returned as it is) or built from the ring's
    name, its attitude in the world and the world's gravity (ValueError if invalid)."""
    if isinstance(support, Support):
        if world_q_support is not None or gravity is not None:
            raise ValueError('give world_q_support and gravity in the Support, not beside it')
        return support
    return Support.of(support, world_q_support, gravity)


class WorldLoads(NamedTuple):
    """The world's loads at N poses, in ring_a's frame: ``gravity`` (N, 3) [m/s²], the tool-centre
    point ``tool_point`` (N, 3) [m] and the tool wrench ``tool_force`` (N, 3) [N] and
    ``tool_torque`` (N, 3) [N m] applied to ring_b there (zeros without a tool wrench)."""

    gravity: np.ndarray
    tool_point: np.ndarray
    tool_force: np.ndarray
    tool_torque: np.ndarray


def tool_wrench_in_support(geometry: RobotGeometry, support: Support,
                           b_R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tool wrench (force, torque) (N, 3) in ring_b's frame, for ring_b turned by b_R (N, 3, 3)
    in the supporting ring's frame (the identity when ring_b supports)."""
    w = geometry.tool_wrench
    n = b_R.shape[0]
    if w is None:
        return np.zeros((n, 3)), np.zeros((n, 3))
    if w.frame == 'tool':
        R = quat_xyzw_to_matrix(geometry.tool.quaternion_xyzw)
        return np.tile(R @ w.force, (n, 1)), np.tile(R @ w.torque, (n, 1))
    in_support = support.world_R_support.T
    return (np.einsum('nji,j->ni', b_R, in_support @ w.force),
            np.einsum('nji,j->ni', b_R, in_support @ w.torque))


def world_loads(geometry: RobotGeometry, support: Support, position: np.ndarray,
                rotation: np.ndarray) -> WorldLoads:
    """:class:`WorldLoads` for ring_b at ``position`` (N, 3), ``rotation`` (N, 3, 3) in ring_a."""
    n = position.shape[0]
    if support.index == 0:
        gravity = np.tile(support.gravity_in_support, (n, 1))
        b_R = rotation
    else:
        gravity = np.einsum('nij,j->ni', rotation, support.gravity_in_support)
        b_R = np.broadcast_to(np.eye(3), (n, 3, 3))
    force_b, torque_b = tool_wrench_in_support(geometry, support, b_R)
    tcp = np.zeros(3) if geometry.tool is None else geometry.tool.position
    return WorldLoads(gravity=gravity,
                      tool_point=position + np.einsum('nij,j->ni', rotation, tcp),
                      tool_force=np.einsum('nij,nj->ni', rotation, force_b),
                      tool_torque=np.einsum('nij,nj->ni', rotation, torque_b))
