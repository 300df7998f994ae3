"""The supporting ring's world attitude as the odometry reports it
(:data:`rrps_interfaces.climb.SUPPORT_POSE`), for the driver's gravity and teleop's load guards::

    follower = SupportFollower(Support.of('ring_a', q_start), timeout=1.0)
    follower.on_message('world', 'ring_a', q, now)      # a SUPPORT_POSE arrived
    new = follower.update(current, now)                 # a Support to ground, or None

Only a fresh message for the supporting ring that turns the attitude by more than ``tolerance`` is
used; else the last known attitude, never a guess
(:meth:`SupportFollower.report`). Contract: docs/architecture.md, 'The supporting ring's attitude'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.names import RINGS, WORLD_FRAME
from rrps_description.pose import QUATERNION_TOLERANCE, InvalidPose, validate_pose
from rrps_description.rotations import rotation_angle_between
from rrps_description.world import Support
from rrps_interfaces.driver import SupportSource

__all__ = ['SupportFollower', 'SupportReport', 'DEFAULT_TIMEOUT', 'DEFAULT_TOLERANCE']

#: How long [s] a SUPPORT_POSE counts as fresh (the climb node sends one per chained pose, 50 Hz).
DEFAULT_TIMEOUT = 1.0
#: The smallest turn [rad] of the attitude that grounds the support again.
DEFAULT_TOLERANCE = 1e-4


@dataclass(frozen=True)
class SupportReport:
    """What a reader computes with: the ``support`` in use, where its attitude comes from
    (``source``), the age [s] of the newest accepted message (None: none yet), the messages
    rejected so far and the last rejection's reason."""

    support: Support
    source: SupportSource
    age: float | None
    rejected: int
    rejection: str

    @property
    def stale(self) -> bool:
        return self.source is SupportSource.STALE

    def status_values(self, support: Support | None = None) -> dict:
        """The support fields of a driver's status (``DriverStatus``), of ``support`` (default:
        the one in use)."""
        support = self.support if support is None else support
        return {'support_ring': support.ring, 'world_q_support': tuple(float(v) for v in support.world_q_support),
                'support_source': self.source, 'support_age': None if self.age is None else round(self.age, 3),
                'support_rejected': self.rejected}

    def text(self) -> str:
        """One line for a status message: the ring, the source and the age."""
        age = '' if self.age is None else f', {self.age:.1f} s old'
        return f'support {self.support.ring}: attitude from {self.source.value}{age}'


class SupportFollower:
    """Follows :data:`~rrps_interfaces.climb.SUPPORT_POSE` (see the module docstring); ``start``:
    the support the reader starts with (its parameters)."""

    def __init__(self, start: Support, *, timeout: float = DEFAULT_TIMEOUT, tolerance: float = DEFAULT_TOLERANCE):
        if not (math.isfinite(timeout) and timeout > 0.0):
            raise ValueError(f'timeout must be finite and > 0 [s], got {timeout!r}')
        if not (math.isfinite(tolerance) and tolerance >= 0.0):
            raise ValueError(f'tolerance must be finite and >= 0 [rad], got {tolerance!r}')
        self.timeout, self.tolerance = float(timeout), float(tolerance)
        self.current = start
        self.rejected = 0
        self.rejection = ''
        self._ring: str | None = None          # the newest accepted message: its ring,
        self._quaternion: np.ndarray | None = None  # its attitude
        self._received = -math.inf             # and its receipt time [s]

    def on_message(self, frame_id: str, ring: str, quaternion_xyzw, now: float) -> bool:
        """A SUPPORT_POSE received at ``now`` [s]: kept when well-formed (True), else rejected
        with the reason in :attr:`rejection` (False)."""
        if frame_id != WORLD_FRAME:
            return self._reject(f'frame {frame_id!r} is not {WORLD_FRAME!r}')
        if ring not in RINGS:
            return self._reject(f'child frame {ring!r} is not a ring ({", ".join(RINGS)})')
        try:
            _, q = validate_pose(np.zeros(3), quaternion_xyzw, tolerance=QUATERNION_TOLERANCE,
                                 what='the supporting ring\'s attitude')
        except InvalidPose as exc:
            return self._reject(str(exc))
        self._ring, self._quaternion, self._received = ring, q, float(now)
        return True

    def _reject(self, reason: str) -> bool:
        self.rejected += 1
        self.rejection = reason
        return False

    def age(self, now: float) -> float | None:
        """Seconds since the newest accepted message (None: none yet)."""
        return None if self._ring is None else max(float(now) - self._received, 0.0)

    def update(self, current: Support, now: float) -> Support | None:
        """The support to ground instead of ``current`` (the reader's, on the ring that supports
        now): the newest message's attitude when it is fresh, for that ring and turned by more
        than ``tolerance`` from it (the world's gravity kept); else None."""
        self.current = current
        age = self.age(now)
        if age is None or age > self.timeout or self._ring != current.ring:
            return None
        turn = float(rotation_angle_between(current.world_q_support, self._quaternion))
        if turn <= self.tolerance:
            return None
        self.current = Support.of(current.ring, self._quaternion, current.gravity)
        return self.current

    def report(self, now: float) -> SupportReport:
        """Where the attitude in use (:attr:`current`) comes from now."""
        age = self.age(now)
        if age is None:
            source = SupportSource.PARAMETERS
        elif age > self.timeout:
            source = SupportSource.STALE
        elif self._ring != self.current.ring:
            source = SupportSource.HANDED_OVER
        else:
            source = SupportSource.ODOMETRY
        return SupportReport(self.current, source, age, self.rejected, self.rejection)
