"""The support of teleop's load guards as the robot climbs: the ring the grippers say carries the
robot (handed over through a_T_b, :func:`rrps_description.world.handed_over`), at the attitude of
a fresh ``odometry/support`` (docs/architecture.md, 'The supporting ring's attitude'). Pure NumPy.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from rrps_description.world import Support, handed_over
from rrps_hardware.support_follower import DEFAULT_TIMEOUT, SupportFollower, SupportReport
from rrps_interfaces.driver import supporting_ring
from rrps_teleop.load_guard import LoadGuard

__all__ = ['LoadSupport']


class LoadSupport:
    """Keeps ``guard`` (a :class:`~rrps_teleop.load_guard.LoadGuard`) on the ring that supports,
    at the odometry's attitude (see the module docstring)."""

    def __init__(self, guard: LoadGuard, *, timeout: float = DEFAULT_TIMEOUT):
        self.guard = guard
        self.follower = SupportFollower(guard.support, timeout=timeout)
        self._a_q_b: np.ndarray | None = None

    @property
    def support(self) -> Support:
        """The guards' support now."""
        return self.guard.support

    def on_slave_pose(self, quaternion_xyzw) -> None:
        """The slave's measured rotation a_T_b (x, y, z, w), for a hand-over."""
        self._a_q_b = np.array(quaternion_xyzw, dtype=float)

    def on_grippers(self, closed: Mapping[str, bool], now: float) -> Support | None:
        """The gripper states {ring: closed} at ``now`` [s]: the guards' new support when the
        carrying ring changed (handed over through the measured pose; kept until a pose is known)
        or the odometry's attitude applies; else None."""
        ring = supporting_ring(closed)
        changed = None
        if ring is not None and ring != self.guard.support.ring and self._a_q_b is not None:
            changed = handed_over(self.guard.support, self._a_q_b, ring)
            self.guard.set_support(changed)
        return self._follow(now) or changed

    def on_odometry(self, frame_id: str, ring: str, quaternion_xyzw, now: float) -> bool:
        """An ``odometry/support`` (its frame, child frame and rotation) received at ``now`` [s]:
        False when it is malformed (the reason in ``follower.rejection``); followed at once."""
        accepted = self.follower.on_message(frame_id, ring, quaternion_xyzw, now)
        self._follow(now)
        return accepted

    def _follow(self, now: float) -> Support | None:
        new = self.follower.update(self.guard.support, now)
        if new is not None:
            self.guard.set_support(new)
        return new

    def report(self, now: float) -> SupportReport:
        """The support in use and where its attitude comes from."""
        self.follower.current = self.guard.support
        return self.follower.report(now)
