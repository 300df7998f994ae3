"""The two grippers of a climbing robot, with the interlock that keeps it on the structure.

Pure Python, no ROS import. A ring's gripper is closed (gripping the structure) or open; the
robot must always grip with at least one ring, so opening one ring is refused while the other
is open (the paper's climbing gait alternates: close the free ring, then open the other)::

    grippers = Grippers({'ring_a': 'clamp', 'ring_b': 'clamp'})   # both closed at start
    ok, message = grippers.set('ring_b', close=False)             # open ring_b: accepted
    ok, message = grippers.set('ring_a', close=False)             # refused: ring_b is open
"""

from __future__ import annotations

from typing import Mapping

from rrps_description.names import RINGS

__all__ = ['Grippers']


class Grippers:
    """Open/closed state of both rings' grippers; ``kinds`` from the robot description.

    A ring whose gripper kind is ``'none'`` has no gripper: it counts as permanently closed
    (fixed to its base) and cannot be set.
    """

    def __init__(self, kinds: Mapping[str, str], closed: Mapping[str, bool] | None = None):
        missing = [ring for ring in RINGS if ring not in kinds]
        if missing:
            raise ValueError(f'gripper kinds missing for {missing}')
        self.kinds = {ring: kinds[ring] for ring in RINGS}
        closed = dict(closed or {ring: True for ring in RINGS})
        if not any(closed.get(ring, True) for ring in RINGS):
            raise ValueError('at least one ring must start closed')
        self.closed = {ring: bool(closed.get(ring, True)) or self.kinds[ring] == 'none' for ring in RINGS}

    @staticmethod
    def other(ring: str) -> str:
        return RINGS[1] if ring == RINGS[0] else RINGS[0]

    def set(self, ring: str, close: bool) -> tuple[bool, str]:
        """Close (``close=True``) or open a ring's gripper; (accepted, message).

        Refused: an unknown ring, a ring without a gripper, and opening a ring while the other
        one is open (the robot would let go of the structure).
        """
        if ring not in RINGS:
            return False, f'unknown ring {ring!r}, expected one of {RINGS}'
        if self.kinds[ring] == 'none':
            return False, f'{ring} has no gripper'
        if close:
            already = self.closed[ring]
            self.closed[ring] = True
            return True, f'{ring} {"already " if already else ""}closed'
        other = self.other(ring)
        if not self.closed[other]:
            return False, f'refused to open {ring}: {other} is open (the robot would let go)'
        already = not self.closed[ring]
        self.closed[ring] = False
        return True, f'{ring} {"already " if already else ""}open'

    def positions(self) -> list[float]:
        """[ring_a, ring_b], 1.0 = closed, 0.0 = open (the grippers/state convention)."""
        return [1.0 if self.closed[ring] else 0.0 for ring in RINGS]
