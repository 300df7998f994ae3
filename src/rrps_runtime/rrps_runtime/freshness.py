"""Staleness of command streams without synchronised clocks (:class:`CommandFreshness`, one per stream), and the ages
of received commands (:class:`CommandAges`, for /diagnostics) and other durations of the last seconds
(:class:`RecentDurations`). Pure Python and NumPy, no ROS import."""

from __future__ import annotations

import collections
import math

import numpy as np

__all__ = ['RejectedCommand', 'StaleCommand', 'CommandFreshness', 'RecentDurations', 'CommandAges']


class RejectedCommand(ValueError):
    """A command that must not be acted on; the message says why."""


class StaleCommand(RejectedCommand):
    """A command too old (or stamped ahead, or unstamped) to be acted on."""


class _SenderClock:
    """One sender clock seen on a stream: its offset is the smallest receipt-minus-stamp [s] of
    its messages over the last ``window`` s (the clocks' offset plus the fastest delivery;
    a sliding minimum, so slow drift between the clocks is followed)."""

    def __init__(self, d: float, receipt: float, window: float, *, fixed: bool = False):
        self.window = window
        self.fixed = fixed                 # the synchronised-clocks sender: offset stays 0
        self.first_receipt = receipt
        self.last_receipt = receipt
        self.count = 0
        self._minima: collections.deque = collections.deque()  # (receipt, d), d increasing
        self.add(d, receipt)

    @property
    def offset(self) -> float:
        return 0.0 if self.fixed else self._minima[0][1]

    def matches(self, d: float, timeout: float, future_tolerance: float) -> bool:
        return self.offset - future_tolerance <= d <= self.offset + timeout

    def add(self, d: float, receipt: float) -> None:
        self.count += 1
        self.last_receipt = receipt
        while self._minima and self._minima[-1][1] >= d:
            self._minima.pop()
        self._minima.append((receipt, d))
        while receipt - self._minima[0][0] > self.window:
            self._minima.popleft()


class CommandFreshness:
    """Staleness of one command stream, also when the sender's clock is not the receiver's.

    A command shows d = receipt - stamp = its delay + the clocks' offset. Each sender clock has an offset (0 for
    synchronised clocks, else the smallest d of its last ``window`` s); a command is fresh for it when d lies in
    [offset - ``future_tolerance``, offset + ``timeout``], and its age is d - offset. While the stream is live
    (a command accepted less than ``switch_silence`` s ago) only its sender's fresh commands pass; after silence a
    known clock's do; a new clock is learned after ``confirm_count`` commands spanning ``confirm_time`` s. The
    limits of this (a lasting delay looks like an offset): docs/deployment.md, "Time and command freshness".
    """

    def __init__(self, timeout: float, *, future_tolerance: float = 0.05,
                 confirm_count: int = 5, confirm_time: float = 0.2,
                 switch_silence: float = 1.0, window: float = 10.0):
        if not (timeout > 0.0 and future_tolerance >= 0.0 and confirm_count >= 1
                and confirm_time >= 0.0 and switch_silence >= 0.0 and window > 0.0):
            raise ValueError('timeout and window must be > 0, the other limits >= 0')
        self.timeout = float(timeout)
        self.future_tolerance = float(future_tolerance)
        self.confirm_count = int(confirm_count)
        self.confirm_time = float(confirm_time)
        self.switch_silence = float(switch_silence)
        self.window = float(window)
        self._synchronised = _SenderClock(0.0, -math.inf, window, fixed=True)
        self.senders: list[_SenderClock] = [self._synchronised]
        self._live: _SenderClock | None = None
        self._last_accepted = -math.inf
        self._candidate: _SenderClock | None = None

    def check(self, stamp: float, receipt: float) -> float:
        """The command's age [s] if it may be acted on, else StaleCommand saying why."""
        if stamp == 0.0:
            raise StaleCommand('command is unstamped (header.stamp = 0): its age cannot be checked')
        d = receipt - stamp
        if not math.isfinite(d):
            raise StaleCommand(f'command is stale or unstamped: its stamp {stamp!r} is not a time')
        tol, timeout = self.future_tolerance, self.timeout
        if receipt - self._last_accepted < self.switch_silence:
            live = self._live
            if live.matches(d, timeout, tol):
                return self._accept(live, d, receipt)
            age = d - live.offset
            clock = '' if live.fixed else " (by its sender's clock)"
            if age < 0.0:
                raise StaleCommand(f'command is stamped {-age:.3f} s ahead of its stream{clock}: '
                                      'a clock jump or another sender while the stream is live')
            raise StaleCommand(f'command is stale: {age:.3f} s old > timeout {timeout:.3f} s{clock}')
        self.senders = [s for s in self.senders if s.fixed or receipt - s.last_receipt <= 60.0]
        for sender in self.senders:
            if sender.matches(d, timeout, tol):
                return self._accept(sender, d, receipt)
        return self._learn(d, receipt)

    def _accept(self, sender: _SenderClock, d: float, receipt: float) -> float:
        sender.add(d, receipt)
        self._live, self._last_accepted, self._candidate = sender, receipt, None
        return max(d - sender.offset, 0.0)

    def _learn(self, d: float, receipt: float) -> float:
        c = self._candidate
        if c is None or not c.matches(d, self.timeout, self.future_tolerance):
            self._candidate = c = _SenderClock(d, receipt, self.window)
        else:
            c.add(d, receipt)
        if c.count >= self.confirm_count and receipt - c.first_receipt >= self.confirm_time:
            self.senders.append(c)
            return self._accept(c, d, receipt)
        side = 'behind' if d > 0 else 'ahead of'
        raise StaleCommand(f'command is stale or from a clock {abs(d):.3f} s {side} this one: '
                              f'confirming the new sender clock ({c.count}/{self.confirm_count})')


class RecentDurations:
    """Durations [s] seen over the last ``window`` s (a command's age, a hop's latency); ``summary()``
    gives their count and p50, p99 and max in ms."""

    def __init__(self, window: float = 10.0, max_samples: int = 10_000):
        if not (window > 0.0 and max_samples > 0):
            raise ValueError('window must be > 0 s and max_samples > 0')
        self.window = window
        self._samples: collections.deque = collections.deque(maxlen=max_samples)

    def add(self, now: float, duration: float) -> None:
        """One duration [s], seen at ``now`` [s]."""
        self._samples.append((now, duration))

    def copy(self) -> RecentDurations:
        """An independent copy: taken under the lock of the thread that adds, summarised outside it."""
        other = RecentDurations(self.window, self._samples.maxlen)
        other._samples.extend(self._samples)
        return other

    def summary(self, now: float) -> tuple[int, float | None, float | None, float | None]:
        """(count, p50, p99, max) [ms] of the durations seen in the window before ``now``; None without one."""
        while self._samples and now - self._samples[0][0] > self.window:
            self._samples.popleft()
        if not self._samples:
            return 0, None, None, None
        ms = 1e3 * np.fromiter((d for _, d in list(self._samples)), dtype=float)
        p50, p99 = np.percentile(ms, [50.0, 99.0])
        return len(ms), float(p50), float(p99), float(np.max(ms))


class CommandAges:
    """Ages [s] of the commands a node received (receipt time minus stamp) over the last ``window`` s;
    ``summary()`` gives their count, the stale ones since the start and p50, p99 and max in ms, for /diagnostics."""

    def __init__(self, window: float = 10.0, max_samples: int = 10_000):
        self._ages = RecentDurations(window, max_samples)
        self.window = window
        self.stale = 0

    def add(self, now: float, age: float, *, stale: bool = False) -> None:
        """One command received at ``now`` [s] that was ``age`` [s] old."""
        self._ages.add(now, age)
        self.stale += bool(stale)

    def summary(self, now: float) -> dict[str, float | int]:
        """{'command_count', 'command_stale_total', 'command_age_p50_ms', ..._p99_ms, ..._max_ms}."""
        count, p50, p99, worst = self._ages.summary(now)
        out: dict[str, float | int] = {'command_count': count, 'command_stale_total': self.stale}
        if count:
            out.update(command_age_p50_ms=p50, command_age_p99_ms=p99, command_age_max_ms=worst)
        return out
