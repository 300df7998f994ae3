"""Loads along a timed path while one gripper holds (eq. 19 with the accelerations): actuator
forces J^T f = M ṫ + Q0 (:mod:`rrps_loads.reduced`) and the holding ring's wrench from the whole
robot's momentum balance about its origin (at rest: :func:`rrps_loads.loads.support_wrench`)::

    loads = path_loads(geometry, t, positions, quaternions, support='ring_a', world_q_support=q)
    loads.actuator_forces, loads.holding_margin       # (K, 6) [N], (K,)
    first_violation(geometry, loads)   # the first sample past a limit, or None
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import cross
from rrps_loads.inverse_dynamics import MIN_SAMPLES, check_trajectory, trajectory_twists
from rrps_loads.loads import holding_margin
from rrps_loads.reduced import PlatformPose, body_accelerations, body_velocities, generalized_forces
from rrps_loads.statics import solve_actuator_forces
from rrps_loads.support import Support, support_of

__all__ = ['PathLoads', 'LoadViolation', 'path_twists', 'path_loads', 'loads_at', 'first_violation',
           'ACTUATOR_FORCE', 'HOLDING']

#: The two load limits a path can break.
ACTUATOR_FORCE = 'actuator_force'
HOLDING = 'holding'


def peak_force(actuator_forces: np.ndarray) -> float:
    """The largest |actuator force| of (K, 6) samples [N]."""
    return float(np.max(np.abs(actuator_forces)))


def peak_leg(actuator_forces: np.ndarray) -> int:
    """Index (0-5) of the leg with the largest |force| over (K, 6) samples."""
    return int(np.argmax(np.max(np.abs(actuator_forces), axis=0)))


def min_margin(holding_margin: np.ndarray) -> float:
    """The smallest holding margin of (K,) samples (NaN when all are NaN: no capacity)."""
    return math.nan if np.all(np.isnan(holding_margin)) else float(np.nanmin(holding_margin))


@dataclass(frozen=True)
class PathLoads:
    """Loads at K samples of a path: ``actuator_forces`` (K, 6) [N] (+ = pushing the rings apart);
    ``support_wrench`` (K, 6) [N, N m]: the force and moment (about the holding ring's origin, in
    its frame) the structure exerts on the holding ring; ``holding_margin`` (K,): 1 - the holding
    gripper's utilisation (NaN when the robot gives no capacity)."""

    support: Support
    actuator_forces: np.ndarray
    support_wrench: np.ndarray
    holding_margin: np.ndarray

    @property
    def peak_force(self) -> float:
        """The largest |actuator force| over the path [N]."""
        return peak_force(self.actuator_forces)

    @property
    def peak_leg(self) -> int:
        """Index (0-5) of the leg with the largest |force|."""
        return peak_leg(self.actuator_forces)

    @property
    def min_holding_margin(self) -> float:
        """The smallest holding margin over the path (NaN without a capacity)."""
        return min_margin(self.holding_margin)


@dataclass(frozen=True)
class LoadViolation:
    """The first sample of a path past a load limit: ``limit`` (:data:`ACTUATOR_FORCE` or
    :data:`HOLDING`), ``sample`` (index), ``leg`` (0-5, for a force) or ``ring`` (the holding
    ring), ``value`` (the force [N] or the holding margin) and ``bound`` (max force [N], or 0)."""

    limit: str
    sample: int
    value: float
    bound: float
    leg: int | None = None
    ring: str | None = None

    @property
    def who(self) -> str:
        """'leg_3' or 'ring_a'."""
        return f'leg_{self.leg + 1}' if self.leg is not None else str(self.ring)


def _supporting_wrench(pose: PlatformPose, twist: np.ndarray, twist_dot: np.ndarray) -> np.ndarray:
    """(K, 6): the momentum balance of the module docstring, in the holding ring's frame."""
    g = pose.geometry
    A = body_accelerations(pose, twist, twist_dot)
    W = body_velocities(pose, twist)
    grav = pose.loads.gravity                                          # (K, 3), ring_a's frame
    if pose.support.index == 0:
        origin = np.zeros_like(pose.position)
        held_mass, held_com = g.ring_a_body.mass, np.broadcast_to(g.ring_a_body.com, origin.shape)
    else:
        origin = pose.position
        held_mass, held_com = g.ring_b_body.mass, pose.position + pose.com_b
    o = origin[:, None, :]
    lower = g.lower_link.mass * (A.lower - grav[:, None, :])
    upper = g.upper_link.mass * (A.upper - grav[:, None, :])
    free = pose.free_mass * (A.ring - grav)
    held = -held_mass * grav
    force = free + held + lower.sum(axis=1) + upper.sum(axis=1) - pose.loads.tool_force
    moment = (cross(pose.free_com - origin, free) + cross(held_com - origin, held)
              + cross(pose.lower_com - o, lower).sum(axis=1) + cross(pose.upper_com - o, upper).sum(axis=1)
              + pose.ring_inertia_times(A.ring_angular)
              + cross(W.ring_angular, pose.ring_inertia_times(W.ring_angular))
              + (pose.link_inertia_times(A.link_angular)
                 + cross(W.link_angular, pose.link_inertia_times(W.link_angular))).sum(axis=1)
              - cross(pose.loads.tool_point - origin, pose.loads.tool_force) - pose.loads.tool_torque)
    if pose.support.index == 1:                                        # ring_a's frame -> ring_b's
        force = np.einsum('nji,nj->ni', pose.rotation, force)
        moment = np.einsum('nji,nj->ni', pose.rotation, moment)
    return np.concatenate([force, moment], axis=-1)


def path_twists(t, positions, quaternions_xyzw) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(positions (K, 3), unit sign-continuous quaternions (K, 4), twists (K, 6), their rates
    (K, 6)) of K samples of a_T_b at times ``t``, differentiated from the samples
    (:func:`rrps_loads.inverse_dynamics.trajectory_twists`); with fewer than MIN_SAMPLES samples
    (a gripper phase: one pose) the robot is at rest. ValueError for invalid input."""
    p = np.atleast_2d(np.asarray(positions, dtype=float))
    q = np.atleast_2d(np.asarray(quaternions_xyzw, dtype=float))
    if len(p) >= MIN_SAMPLES:
        t, p, q = check_trajectory(t, p, q)
        return (p, q, *trajectory_twists(t, p, q))
    if np.shape(t) != (len(p),):
        raise ValueError(f't must have shape ({len(p)},), got {np.shape(t)}')
    return p, q, np.zeros((len(p), 6)), np.zeros((len(p), 6))


def path_loads(geometry: RobotGeometry, t, positions, quaternions_xyzw, *, support='ring_a',
               world_q_support=None, gravity=None) -> PathLoads:
    """:class:`PathLoads` along K samples of a_T_b at times ``t`` (K,) [s] (positions (K, 3) [m],
    quaternions (K, 4) x, y, z, w) while ``support`` grips, turned by ``world_q_support`` in a
    world of ``gravity`` (:func:`rrps_loads.support.support_of`). The payload and tool wrench are
    the geometry's. The motion is differentiated from the samples (:func:`path_twists`). Raises
    ValueError for invalid input, SingularPoseError (a ValueError too) at a singular pose."""
    return loads_at(geometry, *path_twists(t, positions, quaternions_xyzw), support=support,
                    world_q_support=world_q_support, gravity=gravity)


def loads_at(geometry: RobotGeometry, positions, quaternions_xyzw, twist, twist_dot, *, support='ring_a',
             world_q_support=None, gravity=None) -> PathLoads:
    """:class:`PathLoads` at N poses of a_T_b (positions (N, 3), quaternions (N, 4)) moving with
    ring_b's twists and their rates (N, 6) (ring_a's frame, as in :mod:`rrps_loads.reduced`), e.g.
    the samples of several paths held by one ring at one attitude, batched. Other arguments and
    errors as :func:`path_loads`."""
    world = support_of(support, world_q_support, gravity)
    p = np.atleast_2d(np.asarray(positions, dtype=float))
    twist, twist_dot = (np.asarray(x, dtype=float) for x in (twist, twist_dot))
    if twist.shape != (len(p), 6) or twist_dot.shape != (len(p), 6):
        raise ValueError(f'twist and twist_dot must have shape ({len(p)}, 6), got {twist.shape}, {twist_dot.shape}')
    if not (np.all(np.isfinite(twist)) and np.all(np.isfinite(twist_dot))):
        raise ValueError('twist and twist_dot must be finite')
    pose = PlatformPose(geometry, p, quaternions_xyzw, world)
    forces = solve_actuator_forces(pose, generalized_forces(pose, twist, twist_dot))
    wrench = _supporting_wrench(pose, twist, twist_dot)
    capacity = geometry.holding.get(world.ring)
    margin = np.full(len(p), np.nan) if capacity is None else holding_margin(capacity, wrench)
    return PathLoads(world, forces, wrench, margin)


def first_violation(geometry: RobotGeometry, loads: PathLoads) -> LoadViolation | None:
    """The first sample where an actuator force exceeds ``geometry.max_force`` (the leg with the
    largest force there) or the holding margin is negative; None when every sample is within."""
    f = np.abs(loads.actuator_forces)
    over = np.any(f > geometry.max_force, axis=1)
    slips = loads.holding_margin < 0.0
    bad = np.flatnonzero(over | slips)
    if not bad.size:
        return None
    k = int(bad[0])
    if over[k]:
        leg = int(np.argmax(f[k]))
        return LoadViolation(ACTUATOR_FORCE, k, float(loads.actuator_forces[k, leg]),
                             float(geometry.max_force), leg=leg)
    return LoadViolation(HOLDING, k, float(loads.holding_margin[k]), 0.0, ring=loads.support.ring)
