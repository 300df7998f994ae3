"""The link budget: which of the robot's samples cross to the operator station, and when (pure, no ROS).

The gates of the link relay (``rrps_bringup.nodes.link_relay_node``): :class:`RateGate` (a state stream at most at
``rate`` Hz, the newest sample once a period has passed, periods kept on a schedule), :class:`ChangeGate` (an event
stream: at once on a change, else at ``rate``), :class:`StatusTable` (each node's newest status, at once on a change
of level or message, at most every ``min_interval``, else every ``period``).
"""

from __future__ import annotations

import math
from typing import Hashable

__all__ = ['RateGate', 'ChangeGate', 'StatusTable']


class RateGate:
    """Admits a stream's samples at most ``rate`` times a second (rate 0: none)."""

    def __init__(self, rate: float):
        if not (math.isfinite(rate) and rate >= 0.0):
            raise ValueError(f'rate must be >= 0 Hz, got {rate!r}')
        self.period = 1.0 / rate if rate > 0.0 else math.inf
        self._next = -math.inf

    @property
    def enabled(self) -> bool:
        return math.isfinite(self.period)

    def admit(self, t: float) -> bool:
        """Whether the sample received at ``t`` [s] goes out."""
        if not self.enabled or t < self._next:
            return False
        # on schedule while the samples keep up; from now on after a gap
        self._next = self._next + self.period if t - self._next < self.period else t + self.period
        return True


class ChangeGate(RateGate):
    """Admits a sample at once when its ``key`` differs from the last admitted one, else at
    most ``rate`` times a second."""

    def __init__(self, rate: float):
        super().__init__(rate)
        self._key: Hashable = object()

    def admit(self, t: float, key: Hashable = None) -> bool:  # type: ignore[override]
        changed = key != self._key
        if changed:
            self._next = t + self.period if self.enabled else math.inf
            self._key = key
            return True
        return super().admit(t)


class StatusTable:
    """The newest status of each watched node and when the table is due to be sent.

    ``nodes``: the node names whose statuses are kept; ``period`` [s]: the table goes out at
    least this often while it holds a status; ``min_interval`` [s]: a change goes out at once,
    but not sooner than this after the last send."""

    def __init__(self, nodes, *, period: float, min_interval: float = 0.1):
        if not period > 0.0 or not 0.0 <= min_interval <= period:
            raise ValueError(f'need period > 0 and 0 <= min_interval <= period, got {period}, {min_interval}')
        self.nodes = frozenset(nodes)
        self.period = float(period)
        self.min_interval = float(min_interval)
        self._statuses: dict[str, tuple[Hashable, object]] = {}
        self._changed = False
        self._sent = -math.inf

    def offer(self, node: str, name: str, key: Hashable, status: object) -> bool:
        """A status of ``node`` (its ``name`` on /diagnostics, ``key`` its level and message):
        kept when the node is watched; whether it was."""
        if node not in self.nodes:
            return False
        old = self._statuses.get(name)
        self._changed |= old is None or old[0] != key
        self._statuses[name] = (key, status)
        return True

    def due(self, t: float) -> bool:
        """Whether the table should go out at ``t`` [s]."""
        if not self._statuses:
            return False
        since = t - self._sent
        return since >= self.period or (self._changed and since >= self.min_interval)

    def take(self, t: float) -> list:
        """The statuses to send now (in name order); the table is then sent as of ``t``."""
        self._sent, self._changed = t, False
        return [status for _, (_, status) in sorted(self._statuses.items())]
