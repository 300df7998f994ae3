"""Loads of an RRPS robot at rest on either ring: actuator forces, joint reactions, the support's
reaction wrench and the gripper's holding margin (paper eq. 19 at rest and its multipliers).

Batch NumPy over N poses, for planners, guards and previews::

    sol = static_solution(geometry, (positions, quaternions), support='ring_b',
                          world_q_support=q_wall)
    sol.actuator_forces       # (N, 6) [N], + pushes the rings apart
    sol.holding_margin        # (N,) 1 - the supporting gripper's utilisation (< 0: it slips)

Each leg is one body between its joints (:mod:`rrps_loads.statics`): the spherical joint carries
no moment and the universal joint's torque vanishes at rest, so ring_b pushes on leg i with
R_S = -(f_i u_i + w_i) at the spherical joint and ring_a with R_U = f_i u_i - w'_i at the
universal joint (w, w': the leg's weight shares). They are the multipliers of those joints'
rows of eq. 19 (eqs. 3-4), with the sign of a force on the leg. The support's wrench follows
from the supporting ring's own balance: its weight, what it carries and the legs' reactions.
Vectors are in the supporting ring's frame, moments about its origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.loads import GripperCapacity
from rrps_description.pose import Pose
from rrps_description.rotations import cross
from rrps_kinematics.jacobian import inverse_jacobian
from rrps_loads.reduced import assembled_pose
from rrps_loads.statics import leg_weight_shares, solve_transposed, static_load
from rrps_loads.support import Support, support_of, tool_wrench_in_support, world_loads

__all__ = ['StaticSolution', 'static_solution', 'support_wrench', 'holding_margin']


@dataclass(frozen=True)
class StaticSolution:
    """The robot at rest at N poses (a single pose drops the leading N).

    ``actuator_forces`` (N, 6) [N] (+ = pushing the rings apart); ``universal_reactions`` and
    ``spherical_reactions`` (N, 6, 3) [N]: the force ring_a exerts on each leg at its universal
    joint and ring_b at its spherical joint; ``support_wrench`` (N, 6) [N, N m]: the force and
    moment (about the supporting ring's origin) the structure exerts on the supporting ring;
    ``holding_margin`` (N,): 1 - the supporting gripper's utilisation (:func:`holding_margin`;
    NaN when the robot gives no capacity). Vectors in the supporting ring's frame.
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
    ring_b, the tool wrench. Everything in the supporting ring's frame."""
    g = support.gravity_in_support
    if support.index == 0:
        body, anchors = geometry.ring_a_body, geometry.ring_a_anchors
        force = joint_reactions.sum(axis=-2) - body.mass * g
        moment = cross(anchors, joint_reactions).sum(axis=-2) - body.mass * cross(body.com, g)
    else:
        body, anchors = geometry.ring_b_body, geometry.ring_b_anchors
        tool_force, tool_torque = tool_wrench_in_support(geometry, support, np.eye(3)[None])
        tcp = np.zeros(3) if geometry.tool is None else geometry.tool.position
        force = joint_reactions.sum(axis=-2) - body.mass * g - tool_force
        moment = (cross(anchors, joint_reactions).sum(axis=-2) - body.mass * cross(body.com, g)
                  - cross(tcp, tool_force) - tool_torque)
    if joint_torques is not None:
        moment = moment + joint_torques.sum(axis=-2)
    return np.concatenate([force, moment], axis=-1)


def static_solution(geometry: RobotGeometry, a_T_b, *, support='ring_a', world_q_support=None,
                    gravity=None, payload=None, tool_wrench=None) -> StaticSolution:
    """The robot at rest at the poses ``a_T_b`` (a :class:`Pose`, or positions (N, 3) and
    quaternions (N, 4) x, y, z, w) on the ``support`` ring, turned by ``world_q_support`` (default
    upright) in a world of ``gravity`` (default (0, 0, -9.81) m/s²). ``payload`` and
    ``tool_wrench`` replace the robot's own (``None``: the robot's, from its description).

    Raises ValueError for invalid input, SingularPoseError (a ValueError too) at a singular pose.
    """
    world = support_of(support, world_q_support, gravity)
    if payload is not None or tool_wrench is not None:
        geometry = geometry.with_(payload=payload or geometry.payload,
                                  tool_wrench=tool_wrench or geometry.tool_wrench)
    position, quaternion, single = _pose_batch(a_T_b)
    ik, _, _ = assembled_pose(geometry, position, quaternion)
    loads = world_loads(geometry, world, ik.position, ik.rotation)
    forces = solve_transposed(inverse_jacobian(ik), geometry, static_load(geometry, ik, world, loads))
    w_b, w_a = leg_weight_shares(geometry, ik, loads.gravity)
    push = forces[..., None] * ik.unit_vectors
    universal, spherical = push - w_a, -(push + w_b)
    if world.index == 1:                                  # ring_a's frame -> ring_b's
        universal = np.einsum('nji,nkj->nki', ik.rotation, universal)
        spherical = np.einsum('nji,nkj->nki', ik.rotation, spherical)
    wrench = support_wrench(geometry, world, universal if world.index == 0 else spherical)
    margin = (np.full(len(forces), np.nan) if world.ring not in geometry.holding
              else holding_margin(geometry.holding[world.ring], wrench))
    fields = (forces, universal, spherical, wrench, margin)
    return StaticSolution(world, *(f[0] if single else f for f in fields))


def holding_margin(capacity: GripperCapacity, wrench) -> np.ndarray:
    """1 - the utilisation of a gripper holding ``wrench`` (..., 6): the force and moment (about
    the ring's origin, in its frame) the structure exerts on the gripping ring. 1: unloaded,
    0: at its capacity, < 0: it slips or lets go (:class:`GripperCapacity` gives the models)."""
    w = np.asarray(wrench, dtype=float)
    if w.shape[-1:] != (6,) or not np.all(np.isfinite(w)):
        raise ValueError(f'wrench: expected finite (..., 6) force and moment, got shape {w.shape}')
    force = w[..., :3]
    moment = w[..., 3:] - cross(capacity.contact, force)
    if capacity.kind == 'friction':
        demand = np.hypot(force[..., 2], moment[..., 2] / capacity.radius)
        return 1.0 - demand / (capacity.friction * capacity.clamp_force)
    use = np.stack([np.maximum(-force[..., 2], 0.0) / capacity.axial_force,
                    np.hypot(force[..., 0], force[..., 1]) / capacity.shear_force,
                    np.linalg.norm(moment, axis=-1) / capacity.torque])
    return 1.0 - use.max(axis=0)
