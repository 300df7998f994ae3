"""Turns on this machine between the test processes of one session (pytest-xdist workers): a test
that loads the machine as a robot computer's real-time path does (the CANopen drive simulator and
driver at ``SCHED_RR``: about 1.3 of 2 cores) takes the machine alone, every other test shares it.

Two flock(2) files in a directory of the session: the *turn* (shared, or exclusive) and a *gate*
that a taker holds while it waits for its turn, so that a shared taker arriving while an exclusive
one waits queues behind it instead of starving it. The locks go with their holder's process.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ['MachineTurns']


class MachineTurns:
    """The turns kept in ``directory`` (one per test session; created, not removed here)."""

    def __init__(self, directory: str):
        os.makedirs(directory, exist_ok=True)
        self.gate = os.path.join(directory, 'gate')
        self.turn = os.path.join(directory, 'turn')

    @contextmanager
    def take(self, *, exclusive: bool) -> Iterator[None]:
        """Hold the machine, alone (``exclusive``) or beside the other shared holders, until the block ends."""
        with open(self.gate, 'a') as gate, open(self.turn, 'a') as turn:
            fcntl.flock(gate, fcntl.LOCK_EX)
            try:
                fcntl.flock(turn, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
            finally:
                fcntl.flock(gate, fcntl.LOCK_UN)
            try:
                yield
            finally:
                fcntl.flock(turn, fcntl.LOCK_UN)
