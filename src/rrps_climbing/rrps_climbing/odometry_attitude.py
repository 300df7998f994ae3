"""The supporting ring's world attitude from the climb's odometry (:data:`rrps_interfaces.climb.SUPPORT_POSE`),
and a plan anchored on it.

:class:`SupportPublisher` says when to send it: on a change, else every ``period`` s (a heartbeat).
:func:`anchor_phases` moves a plan rigidly onto the odometry's ring_a, so a preview computes in the
measured attitudes' gravity (docs/architecture.md, 'The supporting ring's attitude'). No ROS import.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Sequence

from rrps_climbing.plan import Phase
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_angle_between
from rrps_interfaces.driver import supporting_ring

__all__ = ['SupportPublisher', 'anchor_phases', 'support_of_odometry']

#: The heartbeat [s] of the supporting ring's pose (readers count it stale after 1 s).
PUBLISH_PERIOD = 0.1
#: A turn [rad] or shift [m] of the supporting ring's pose that is sent at once.
CHANGE = 1e-6


def support_of_odometry(world_T_a: Pose, world_T_b: Pose, closed: Mapping[str, bool] | None) -> tuple[str, Pose] | None:
    """(ring, its world pose) of the ring that supports by the gripper states ``closed``; None
    when they are unknown or both open."""
    ring = None if closed is None else supporting_ring(closed)
    if ring is None:
        return None
    return ring, (world_T_a if ring == 'ring_a' else world_T_b)


class SupportPublisher:
    """When the supporting ring's world pose is due (see the module docstring)."""

    def __init__(self, period: float = PUBLISH_PERIOD):
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f'period must be finite and > 0 [s], got {period!r}')
        self.period = float(period)
        self._last: tuple[str, Pose, float] | None = None

    def due(self, ring: str, pose: Pose, now: float) -> bool:
        """True when (``ring``, ``pose``) at ``now`` [s] must be sent (and is taken as sent)."""
        last = self._last
        if (last is not None and last[0] == ring and now - last[2] < self.period
                and float(rotation_angle_between(last[1].quaternion_xyzw, pose.quaternion_xyzw)) <= CHANGE
                and float(sum((a - b) ** 2 for a, b in zip(last[1].position, pose.position))) <= CHANGE ** 2):
            return False
        self._last = (ring, pose, float(now))
        return True


def anchor_phases(phases: Sequence[Phase], world_T_a: Pose | None) -> list[Phase]:
    """The phases with their world poses moved rigidly so that the first one's ring_a is at
    ``world_T_a`` (the odometry's); the phases as they are when it is None. The kinematic
    paths (a_T_b) are not changed: only where the plan stands in the world."""
    if world_T_a is None or not phases:
        return list(phases)
    correction = world_T_a @ phases[0].world_T_a.inverse()
    return [dataclasses.replace(ph, world_T_a=correction @ ph.world_T_a, world_T_b=correction @ ph.world_T_b)
            for ph in phases]
