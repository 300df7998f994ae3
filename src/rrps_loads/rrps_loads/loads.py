"""Loads of an RRPS robot at rest on either ring (eq. 19 at rest and its multipliers, eqs. 3-4):
actuator forces, joint reactions, the support's wrench and the gripper's holding margin, batched::

    sol = static_solution(geometry, (positions, quaternions), support='ring_b', world_q_support=q_wall)
    sol.actuator_forces       # (N, 6) [N], + pushes the rings apart
    sol.holding_margin        # (N,) 1 - the supporting gripper's utilisation (< 0: it slips)

Vectors are in the supporting ring's frame, moments about its origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.loads import GripperCapacity
from rrps_description.pose import Pose
from rrps_kinematics.backend import kernels_of
from rrps_loads import compiled_statics
from rrps_loads.reduced import assembled_pose
from rrps_loads.statics import rest_statics
from rrps_loads.support import Support, support_of

__all__ = ['StaticSolution', 'static_solution', 'support_wrench', 'holding_margin']


@dataclass(frozen=True)
class StaticSolution:
    """The robot at rest at N poses (a single pose drops the leading N), SI units, supporting ring's frame.

    ``universal_reactions``/``spherical_reactions`` (N, 6, 3): the force ring_a/ring_b exerts on each
    leg; ``support_wrench`` (N, 6): the structure's on the supporting ring, about its origin;
    ``holding_margin`` NaN when the robot gives no capacity.
    """

    support: Support
    actuator_forces: np.ndarray
    universal_reactions: np.ndarray
    spherical_reactions: np.ndarray
    support_wrench: np.ndarray
    holding_margin: np.ndarray


def _pose_batch(a_T_b) -> tuple[np.ndarray, np.ndarray, bool]:
    if isinstance(a_T_b, Pose):
        return a_T_b.position, a_T_b.quaternion_xyzw, True
    try:
        position, quaternion = a_T_b
    except (TypeError, ValueError):
        raise ValueError('a_T_b: expected a Pose or a pair (positions (N, 3), quaternions (N, 4))') from None
    return position, quaternion, np.ndim(position) == 1


def support_wrench(geometry: RobotGeometry, support: Support, joint_reactions: np.ndarray,
                   joint_torques: np.ndarray | None = None) -> np.ndarray:
    """The structure's wrench (N, 6) on the supporting ring, from that ring's balance: the
    ``joint_reactions`` (N, 6, 3) its joints exert on the legs (universal joints for ring_a,
    spherical for ring_b) and their ``joint_torques`` (N, 6, 3) if any, its weight and, for
    ring_b, the tool wrench. Everything in the supporting ring's frame (the kernel
    :func:`rrps_loads.compiled_statics.support_wrenches`)."""
    reactions = np.ascontiguousarray(joint_reactions, dtype=float)
    flat = reactions.reshape(-1, 6, 3)
    s = compiled_statics.statics_arrays(geometry, support)
    out = np.zeros((len(flat), 6))
    kernels = kernels_of(compiled_statics)
    if kernels is compiled_statics:
        kernels.support_wrenches(s, flat, out)
    else:
        out = out.tolist()
        kernels.support_wrenches(type(s)(*(a.tolist() for a in s)), flat.tolist(), out)
        out = np.array(out, dtype=float)
    wrench = out.reshape(reactions.shape[:-2] + (6,))
    if joint_torques is not None:
        wrench[..., 3:] += np.asarray(joint_torques, dtype=float).sum(axis=-2)
    return wrench


def static_solution(geometry: RobotGeometry, a_T_b, *, support='ring_a', world_q_support=None,
                    gravity=None, payload=None, tool_wrench=None) -> StaticSolution:
    """The robot at rest at ``a_T_b`` (a :class:`Pose`, or positions (N, 3) and quaternions (N, 4))
    on ``support`` turned by ``world_q_support``; ``payload``/``tool_wrench`` replace the robot's.
    Raises ValueError, SingularPoseError (a ValueError) at a singular pose."""
    world = support_of(support, world_q_support, gravity)
    if payload is not None or tool_wrench is not None:
        geometry = geometry.with_(payload=payload or geometry.payload,
                                  tool_wrench=tool_wrench or geometry.tool_wrench)
    position, quaternion, single = _pose_batch(a_T_b)
    ik, _, _ = assembled_pose(geometry, position, quaternion)
    rest = rest_statics(geometry, world, ik)
    fields = (rest.forces, rest.universal, rest.spherical, rest.wrench, rest.margin)
    return StaticSolution(world, *(f[0] if single else f for f in fields))


def holding_margin(capacity: GripperCapacity, wrench) -> np.ndarray:
    """1 - the utilisation of a gripper holding ``wrench`` (..., 6): the force and moment (about
    the ring's origin, in its frame) the structure exerts on the gripping ring. 1: unloaded,
    0: at its capacity, < 0: it slips or lets go (:class:`GripperCapacity` gives the models;
    the kernel :func:`rrps_loads.compiled_statics.holding_margins`)."""
    w = np.asarray(wrench, dtype=float)
    if w.shape[-1:] != (6,) or not np.all(np.isfinite(w)):
        raise ValueError(f'wrench: expected finite (..., 6) force and moment, got shape {w.shape}')
    flat = np.ascontiguousarray(w.reshape(-1, 6))
    capacity = compiled_statics.capacity_array(capacity)
    kernels = kernels_of(compiled_statics)
    if kernels is compiled_statics:
        out = np.empty(len(flat))
        kernels.holding_margins(capacity, flat, out)
    else:
        out = [0.0] * len(flat)
        kernels.holding_margins(capacity.tolist(), flat.tolist(), out)
        out = np.array(out, dtype=float)
    return out.reshape(w.shape[:-1])
