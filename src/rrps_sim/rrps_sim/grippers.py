"""The two grippers of a climbing robot, with the interlock that keeps it on the structure.

Pure Python, no ROS import. Opening a ring is refused unless the other ring's sensor reads closed
and it is commanded closed (:meth:`Grippers.set` returns (ok, message)). With ``times`` (the
description's ``gripper_time``) a gripper takes that long to switch, stepped by
:meth:`Grippers.update`, and its sensor (:attr:`Grippers.closed`) shows a switch once complete.
"""

from __future__ import annotations

from typing import Mapping

from rrps_description.motion_limits import GripperTime
from rrps_description.names import RINGS

__all__ = ['Grippers']

#: A travel this close to an end is there (the rounding of its steps).
_ROUNDING = 1e-9


class Grippers:
    """Open/closed state of both rings' grippers; ``kinds`` from the robot description, their
    switching ``times`` (module docstring; None: at once).

    A ring whose gripper kind is ``'none'`` has no gripper: it counts as permanently closed
    (fixed to its base) and cannot be set.
    """

    def __init__(self, kinds: Mapping[str, str], closed: Mapping[str, bool] | None = None,
                 times: Mapping[str, GripperTime] | None = None):
        missing = [ring for ring in RINGS if ring not in kinds]
        if missing:
            raise ValueError(f'gripper kinds missing for {missing}')
        self.kinds = {ring: kinds[ring] for ring in RINGS}
        closed = dict(closed or {ring: True for ring in RINGS})
        if not any(closed.get(ring, True) for ring in RINGS):
            raise ValueError('at least one ring must start closed')
        #: what each gripper is commanded to do (True: close)
        self.commanded = {ring: bool(closed.get(ring, True)) or self.kinds[ring] == 'none' for ring in RINGS}
        self.times = {ring: (times or {}).get(ring, GripperTime(0.0, 0.0)) for ring in RINGS}
        self.travel = {ring: 1.0 if self.commanded[ring] else 0.0 for ring in RINGS}   # 1 closed, 0 open
        self.now: float | None = None   # the time [s] of the last update

    @property
    def closed(self) -> dict[str, bool]:
        """The sensors {ring: closed} (module docstring)."""
        return {ring: self.travel[ring] >= 1.0 or (not self.commanded[ring] and self.travel[ring] > 0.0)
                for ring in RINGS}

    @staticmethod
    def other(ring: str) -> str:
        return RINGS[1] if ring == RINGS[0] else RINGS[0]

    def set(self, ring: str, close: bool) -> tuple[bool, str]:
        """Command a ring's gripper to close (``close=True``) or open; (accepted, message).

        Refused: an unknown ring, a ring without a gripper, and opening a ring while the other
        one is not closed and commanded closed (the robot would let go of the structure).
        """
        if ring not in RINGS:
            return False, f'unknown ring {ring!r}, expected one of {RINGS}'
        if self.kinds[ring] == 'none':
            return False, f'{ring} has no gripper'
        other = self.other(ring)
        if not close and not (self.closed[other] and self.commanded[other]):
            state = 'opening' if self.closed[other] else 'open' if not self.commanded[other] else 'closing'
            return False, f'refused to open {ring}: {other} is {state} (the robot would let go)'
        end = 1.0 if close else 0.0
        already = self.commanded[ring] == close and self.travel[ring] == end
        self.commanded[ring] = bool(close)
        switch = self.times[ring].switch(close)
        if switch <= 0.0:
            self.travel[ring] = end
        word = 'closed' if close else 'open'
        if already:
            return True, f'{ring} already {word}'
        return True, f'{ring} {word}' if self.travel[ring] == end else (
            f'{ring} {"closing" if close else "opening"} ({switch:g} s)')

    def update(self, now: float) -> bool:
        """Move each gripper towards its command up to time ``now`` [s]; True when a sensor
        changed."""
        dt = 0.0 if self.now is None else max(0.0, now - self.now)
        self.now = now
        before = dict(self.closed)
        for ring in RINGS:
            close = self.commanded[ring]
            switch = self.times[ring].switch(close)
            step = 1.0 if switch <= 0.0 else dt / switch
            travel = self.travel[ring] + step if close else self.travel[ring] - step
            self.travel[ring] = 1.0 if travel > 1.0 - _ROUNDING else 0.0 if travel < _ROUNDING else travel
        return self.closed != before

    def positions(self) -> list[float]:
        """[ring_a, ring_b], 1.0 = closed, 0.0 = open (the grippers/state convention)."""
        return [1.0 if self.closed[ring] else 0.0 for ring in RINGS]
