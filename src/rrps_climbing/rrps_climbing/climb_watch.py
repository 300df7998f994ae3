"""What a climbing step watches before it moves: the age of its inputs on this host's monotonic
receipt clock (``state_timeout``, ``operator_timeout``, the driver active).

After a stall of the node's own executor, queued messages may look old: :class:`InputWatch` judges
ages only after a ``state_timeout`` without such a stall.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rrps_interfaces.climb import PauseReason

__all__ = ['ROBOT_STATE', 'OPERATOR', 'INPUTS', 'InputWatch']

#: The inputs a step depends on, by topic: the robot's state, then the operator station.
ROBOT_STATE = ('pose', 'grippers/state')
OPERATOR = 'teleop/status'
INPUTS = (*ROBOT_STATE, OPERATOR)


class InputWatch:
    """Receipt-time watchdog of a climbing step's inputs (see the module docstring)."""

    def __init__(self, *, state_timeout: float, operator_timeout: float,
                 clock: Callable[[], float] = time.monotonic):
        self.state_timeout = float(state_timeout)
        self.operator_timeout = float(operator_timeout)
        self._clock = clock
        self._receipts: dict[str, float | None] = dict.fromkeys(INPUTS)
        self._last_tick_end = clock()
        self._judge_from = self._last_tick_end
        self._tick_start = self._last_tick_end

    def received(self, name: str) -> None:
        """Note the receipt of one of :data:`INPUTS` now."""
        if name not in self._receipts:
            raise ValueError(f'unknown input {name!r}: one of {INPUTS}')
        self._receipts[name] = self._clock()

    def operator_seen(self) -> bool:
        return self._receipts[OPERATOR] is not None

    def operator_heard_since(self, t: float) -> bool:
        """Whether the operator station was heard at or after ``t`` (watch time, :meth:`now`), or
        was never seen (a robot driven without an operator station)."""
        receipt = self._receipts[OPERATOR]
        return receipt is None or receipt >= t

    def now(self) -> float:
        """The watch's clock [s] (monotonic)."""
        return self._clock()

    def tick_started(self) -> None:
        """Call at the start of each of the node's ticks: a late tick is a stall."""
        self._tick_start = self._clock()
        if self._tick_start - self._last_tick_end > 0.5 * self.state_timeout:
            self._judge_from = self._tick_start + self.state_timeout

    def tick_ended(self) -> None:
        """Call at the end of each tick: a long tick (a plan) is a stall."""
        end = self._clock()
        if end - self._tick_start > 0.5 * self.state_timeout:
            self._judge_from = end + self.state_timeout
        self._last_tick_end = end

    def judged(self) -> bool:
        """Whether receipt ages are evidence now (no stall of the node's own for a state_timeout)."""
        return self._clock() >= self._judge_from

    def hold_reason(self, *, driver_active: bool | None) -> PauseReason | None:
        """Why a step must hold now, regardless of stalls (use :meth:`judged` to decide whether
        to act on it while executing); None when it may go on."""
        now = self._clock()
        if any(self._receipts[name] is None or now - self._receipts[name] > self.state_timeout
               for name in ROBOT_STATE):
            return PauseReason.ROBOT_STATE_LOST
        operator = self._receipts[OPERATOR]
        if operator is not None and now - operator > self.operator_timeout:
            return PauseReason.OPERATOR_LINK_LOST
        if driver_active is False:
            return PauseReason.DRIVER_INACTIVE
        return None

    def ages(self) -> str:
        """The inputs' ages, for a human: 'pose 0.25 s old, grippers/state ..., teleop/status never received'."""
        now = self._clock()
        return ', '.join(f'{name} ' + ('never received' if t is None else f'{now - t:.2f} s old')
                         for name, t in self._receipts.items())
