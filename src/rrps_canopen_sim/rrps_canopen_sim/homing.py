"""A simulated drive's homing run: the CiA 402 homing methods rrps runs (17/18, 1/2, 35/37;
IEC 61800-7-201) in the drive's count direction, as docs/connecting-a-robot.md, 'Homing', gives
them. Without limit switches a method that needs one ends in a homing error at the stroke's end.
:class:`HomingRun` drives the axis and says when the home is found; :class:`Phase` gives the
statusword's homing bits. Pure Python."""

from __future__ import annotations

import enum
import math

__all__ = ['HomingRun', 'Phase', 'SWITCH_METHODS', 'INDEX_METHODS', 'HERE_METHODS', 'AT_END']

#: Methods that seek a limit switch: the sign of the count direction towards it.
SWITCH_METHODS = {1: -1, 2: 1, 17: -1, 18: 1}
#: Methods that home on the index pulse after the switch.
INDEX_METHODS = (1, 2)
#: Methods that home where the axis stands.
HERE_METHODS = (35, 37)
#: [m] how near its end the axis is when it is on the switch (a switch at a hard stop).
AT_END = 1e-9


class Phase(enum.Enum):
    """Where a homing run is. Statusword bits 13 (error), 12 (attained), 10 (target reached) in
    homing mode: SEEKING and LEAVING 0 0 0 (in progress), STOPPING 0 1 0 (attained, not yet
    still), DONE 0 1 1 (completed), FAILED 1 0 1 (error, the axis stopped)."""

    SEEKING = 'seeking'      # towards the limit switch
    LEAVING = 'leaving'      # back from the switch towards the index pulse
    STOPPING = 'stopping'
    DONE = 'done'
    FAILED = 'failed'


class HomingRun:
    """One homing run of ``method`` on an axis at ``x`` [m] with ``gain`` [counts/m, signed] over
    ``stroke`` (min, max) [m] (see the module docstring)."""

    def __init__(self, method: int, x: float, gain: float, stroke: tuple[float, float], *, switches: bool,
                 index_pitch: float):
        self.method, self.stroke, self.switches, self.pitch = method, stroke, switches, index_pitch
        self.count_sign = 1 if gain > 0 else -1
        self.home: float | None = None   # [m] the home point found
        self.stop_at = x
        if method in HERE_METHODS:
            self.home, self.phase, self.target = x, Phase.DONE, x
        elif method in SWITCH_METHODS:
            self.phase, self.target = Phase.SEEKING, self._end(SWITCH_METHODS[method])
        else:
            self.phase, self.target = Phase.FAILED, x

    def _end(self, count_side: int) -> float:
        """The stroke's end on the ``count_side`` (-1: where the count is lowest)."""
        return self.stroke[0] if count_side * self.count_sign < 0 else self.stroke[1]

    @property
    def moving(self) -> bool:
        """The axis is driven at the homing speed."""
        return self.phase in (Phase.SEEKING, Phase.LEAVING)

    def advance(self, before: float, x: float) -> float | None:
        """The axis moved from ``before`` to ``x`` [m]: the home point [m] when found in this
        step, else None."""
        if self.phase is Phase.SEEKING and abs(x - self.target) <= AT_END:
            if not self.switches:
                self.phase, self.target = Phase.FAILED, x
                return None
            if self.method in INDEX_METHODS:
                self.phase = Phase.LEAVING
                away = 1.0 if self.target == self.stroke[0] else -1.0
                self.target = self.target + away * 2.0 * self.pitch  # beyond the first pulse: crossed at speed
                return None
            return self._found(self.target, x)  # the switch is at the end
        if self.phase is Phase.LEAVING:
            pulse = self._pulse_between(before, x)
            if pulse is not None:
                return self._found(pulse, x)
        if self.phase is Phase.STOPPING and abs(x - self.stop_at) <= AT_END:
            self.phase = Phase.DONE
        return None

    def _found(self, home: float, x: float) -> float:
        self.home, self.stop_at, self.target, self.phase = home, x, x, Phase.STOPPING
        return home

    def _pulse_between(self, a: float, b: float) -> float | None:
        """The first index pulse passed going from ``a`` to ``b``."""
        lo, hi = min(a, b), max(a, b)
        first = math.ceil((lo - self.stroke[0]) / self.pitch - 0.5)
        last = math.floor((hi - self.stroke[0]) / self.pitch - 0.5)
        if last < first or hi == lo:
            return None
        k = first if b > a else last
        return self.stroke[0] + (k + 0.5) * self.pitch
