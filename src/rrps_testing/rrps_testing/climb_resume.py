"""An operator who resumes a paused climb step, for the tests that run a whole step over ROS on a
loaded machine: a stall of the test's own process can age an input the step watches, which pauses
it (the safe behaviour, tested in tests/node/test_liveness.py), and a paused step waits for
``climb/resume``. No ROS import: the caller gives the service call."""

from __future__ import annotations

from typing import Any, Callable

from rrps_interfaces.climb import ClimbState, ClimbStatus

__all__ = ['MAX_RESUMES', 'Resumer']

#: Resumes at most this many pauses of one step: more means the step itself cannot go on.
MAX_RESUMES = 5


class Resumer:
    """Calls ``resume`` (a ``climb/resume`` call returning its future) when the newest climb status
    says PAUSED, one call at a time, at most ``limit`` times."""

    def __init__(self, resume: Callable[[], Any], limit: int = MAX_RESUMES):
        self._resume = resume
        self.limit = limit
        self.calls: list = []

    def __call__(self, last: ClimbStatus | None) -> None:
        """Look at the newest status (None: none yet) and resume if it is a pause."""
        if (last is not None and last.state is ClimbState.PAUSED and len(self.calls) < self.limit
                and (not self.calls or self.calls[-1].done())):
            self.calls.append(self._resume())
