"""Validation of command streams shared by the nodes: target poses, staleness, velocity limits.

Pure NumPy, no ROS import. Every check raises :class:`RejectedCommand` (a ValueError) with a
message that says why, so a node can keep its last safe command and report the reason::

    target = validate_target(geom, position, quaternion_xyzw, frame_id='ring_a')
    target.lengths, target.minimum          # IK lengths (6,) [m], smallest margin of each limit
    ok, lengths, minimum = pose_limits(geom, position, quaternion_xyzw)   # the fast check alone
    freshness = CommandFreshness(timeout)    # per stream: staleness without synchronised clocks
    age = freshness.check(stamp_s, now_s)   # raises RejectedCommand for a late command
    limit_velocity(current, desired, max_speed, dt)   # joint-space step within max_speed
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass

import numpy as np

from .backend import use_numba
from .geometry import RobotGeometry
from .inverse import inverse_kinematics
from .limits import limit_arrays, margins

__all__ = ['RejectedCommand', 'ValidTarget', 'validate_target', 'pose_limits', 'CommandFreshness',
           'limit_velocity', 'CommandAges']

MARGIN_KINDS = ('stroke', 'universal', 'spherical', 'interference', 'conditioning')
def pose_limits(geometry: RobotGeometry, position, quaternion_xyzw, *,
                backend: str = 'auto') -> tuple[bool, np.ndarray, dict[str, float]]:
    """(within limits, lengths (6,), smallest margin of each kind) of one pose a_T_b.

    The numbers of :func:`rrps_kinematics.limits.margins` (``Margins.minimum``, ``ok``), from a
    numba kernel when available (a few microseconds). ``quaternion_xyzw`` must be unit.
    """
    # fresh writable copies: the kernel is compiled for one argument type only (a read-only array,
    # e.g. a robot's home quaternion, would be another type and compile again on first use)
    p = np.array(position, dtype=float)
    q = np.array(quaternion_xyzw, dtype=float)
    if use_numba(backend):
        from .compiled_limits import N_MARGINS, pose_margins
        out = np.empty(N_MARGINS)
        lengths = np.empty(6)
        pose_margins(limit_arrays(geometry), p, q, out, lengths)
        minimum = dict(zip(MARGIN_KINDS, (float(v) for v in out[:5])))
        ok = bool(np.all(out[:5] >= 0.0) and out[5] > 0.0)
        return ok, lengths, minimum
    m = margins(geometry, inverse_kinematics(geometry, p, q))
    return bool(m.ok), np.array(m.lengths), {k: float(v) for k, v in m.minimum.items()}


class RejectedCommand(ValueError):
    """A command that must not be acted on; the message says why."""


@dataclass(frozen=True)
class ValidTarget:
    """A target pose a_T_b that passed every check: unit quaternion, lengths [m] and the
    smallest margin of each limit (``stroke``, ``universal``, ``spherical``, ``interference``,
    ``conditioning``; as :attr:`rrps_kinematics.limits.Margins.minimum`)."""

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    lengths: np.ndarray
    minimum: dict


def validate_target(geometry: RobotGeometry, position, quaternion_xyzw, *, frame_id: str,
                    expected_frame: str = 'ring_a', quaternion_tolerance: float = 1e-3) -> ValidTarget:
    """Check a target pose of ring_b in ring_a and solve its IK (eq. 1).

    Rejected: a frame other than ``expected_frame``, NaN/inf, a quaternion whose norm differs
    from 1 by more than ``quaternion_tolerance`` (a nearly unit one is normalised), and poses
    outside the stroke, joint-angle, interference or conditioning limits (:func:`margins`).
    """
    if frame_id != expected_frame:
        raise RejectedCommand(f"frame_id is {frame_id!r}, expected {expected_frame!r}")
    p = np.asarray(position, dtype=float)
    q = np.asarray(quaternion_xyzw, dtype=float)
    if p.shape != (3,) or q.shape != (4,):
        raise RejectedCommand(f'pose must be a position (3,) and a quaternion (4,), got '
                              f'{p.shape} and {q.shape}')
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise RejectedCommand('pose contains NaN or infinite values')
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > quaternion_tolerance:
        raise RejectedCommand(f'quaternion norm {norm:.6g} is not 1 (tolerance {quaternion_tolerance:g})')
    q = q / norm
    ok, lengths, minimum = pose_limits(geometry, p, q)
    if not ok:  # word the reason with the reference implementation
        reason = margins(geometry, inverse_kinematics(geometry, p, q)).reason
        raise RejectedCommand(f'pose outside the limits: {reason}')
    return ValidTarget(position=p, quaternion_xyzw=q, lengths=lengths, minimum=minimum)


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

    A command stamped ``stamp`` (sender's clock) received at ``receipt`` (this node's clock)
    shows d = receipt - stamp = its delay + the offset between the clocks. Each sender clock
    seen on the stream has an offset: 0 for synchronised clocks (NTP-synchronised hosts, the
    same machine), else the smallest d of its last ``window`` s (its offset plus the fastest
    delivery). A command is fresh for a sender when d lies within [offset -
    ``future_tolerance``, offset + ``timeout``]; its age is d - offset. The policy:

    1. While the stream is live (a command was accepted less than ``switch_silence`` s ago),
       a command must be fresh for the sender of that stream: anything else is late (a
       delayed copy, a queue flushing) and refused, also when the delay happens to look like
       another clock.
    2. After silence, a command fresh for synchronised clocks or for a sender clock learned
       before is accepted at once and its sender makes the stream live again.
    3. Else it comes from a new sender clock (or is late): refused until ``confirm_count``
       commands spanning ``confirm_time`` s agree on the new clock, which is then learned.

    A receipt-time watchdog completes it: the receiving node holds when no command arrived for
    ``timeout`` s, whatever the stamps say. Limits (without synchronised clocks the one-way
    delay cannot be measured, only d): a new sender's first stream is taken as on time, so a
    delay it carries from its first message on is indistinguishable from a clock offset; and
    a stream whose every command arrives late for longer than ``switch_silence`` +
    ``confirm_time`` looks like a sender switch and is learned as a new clock. Single late
    commands and delays shorter than that are never acted on; the operator station's
    round-trip measurement (teleop holds above 0.3 s) bounds the rest.
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
        """The command's age [s] if it may be acted on, else RejectedCommand saying why."""
        if stamp == 0.0:
            raise RejectedCommand('command is unstamped (header.stamp = 0): its age cannot be checked')
        d = receipt - stamp
        if not math.isfinite(d):
            raise RejectedCommand(f'command is stale or unstamped: its stamp {stamp!r} is not a time')
        tol, timeout = self.future_tolerance, self.timeout
        if receipt - self._last_accepted < self.switch_silence:
            live = self._live
            if live.matches(d, timeout, tol):
                return self._accept(live, d, receipt)
            age = d - live.offset
            clock = '' if live.fixed else " (by its sender's clock)"
            if age < 0.0:
                raise RejectedCommand(f'command is stamped {-age:.3f} s ahead of its stream{clock}: '
                                      'a clock jump or another sender while the stream is live')
            raise RejectedCommand(f'command is stale: {age:.3f} s old > timeout {timeout:.3f} s{clock}')
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
        raise RejectedCommand(f'command is stale or from a clock {abs(d):.3f} s {side} this one: '
                              f'confirming the new sender clock ({c.count}/{self.confirm_count})')


def limit_velocity(current, desired, max_speed: float, dt: float) -> np.ndarray:
    """The point on the straight joint-space line current -> desired that no leg reaches
    faster than ``max_speed`` [m/s] over ``dt`` [s] (the whole step is scaled, so all legs
    arrive together and the direction of motion is kept)."""
    current = np.asarray(current, dtype=float)
    delta = np.asarray(desired, dtype=float) - current
    if not (max_speed > 0.0 and dt >= 0.0):
        raise ValueError(f'max_speed must be > 0 and dt >= 0, got {max_speed}, {dt}')
    largest = float(np.max(np.abs(delta))) if delta.size else 0.0
    allowed = max_speed * dt
    if math.isinf(max_speed) or largest <= allowed:
        return current + delta
    return current + delta * (allowed / largest)


class CommandAges:
    """Ages [s] of the commands a node received (receipt time minus stamp) over the last
    ``window`` s: how late the commands reach it (transport plus the receiving executor).

    ``summary()`` gives the count in the window, the stale ones since the start (older than the
    node's timeout) and the 50th and 99th percentiles and the maximum in milliseconds, for
    /diagnostics.
    """

    def __init__(self, window: float = 10.0, max_samples: int = 10_000):
        if not (window > 0.0 and max_samples > 0):
            raise ValueError('window must be > 0 s and max_samples > 0')
        self.window = window
        self._samples: collections.deque = collections.deque(maxlen=max_samples)
        self.stale = 0

    def add(self, now: float, age: float, *, stale: bool = False) -> None:
        """One command received at ``now`` [s] that was ``age`` [s] old."""
        self._samples.append((now, age))
        self.stale += bool(stale)

    def summary(self, now: float) -> dict[str, float | int]:
        """{'command_count', 'command_stale_total', 'command_age_p50_ms', ..._p99_ms, ..._max_ms}."""
        while self._samples and now - self._samples[0][0] > self.window:
            self._samples.popleft()
        out: dict[str, float | int] = {'command_count': len(self._samples),
                                       'command_stale_total': self.stale}
        if self._samples:
            ages = 1e3 * np.fromiter((a for _, a in self._samples), dtype=float)
            p50, p99 = np.percentile(ages, [50.0, 99.0])
            out.update(command_age_p50_ms=float(p50), command_age_p99_ms=float(p99),
                       command_age_max_ms=float(np.max(ages)))
        return out
