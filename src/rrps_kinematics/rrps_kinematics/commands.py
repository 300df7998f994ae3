"""Validation of command streams shared by the nodes: target poses, staleness, velocity limits.

Pure NumPy, no ROS import. Every check raises :class:`RejectedCommand` (a ValueError) with a
message that says why, so a node can keep its last safe command and report the reason::

    target = validate_target(geom, position, quaternion_xyzw, frame_id='ring_a')
    target.lengths, target.minimum          # IK lengths (6,) [m], smallest margin of each limit
    ok, lengths, minimum = pose_limits(geom, position, quaternion_xyzw)   # the fast check alone
    check_fresh(stamp_s, now_s, timeout)     # raises when the command is older than timeout
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

__all__ = ['RejectedCommand', 'ValidTarget', 'validate_target', 'pose_limits', 'check_fresh',
           'limit_velocity', 'CommandAges']

MARGIN_KINDS = ('stroke', 'universal', 'spherical', 'interference', 'conditioning')
def pose_limits(geometry: RobotGeometry, position, quaternion_xyzw, *,
                backend: str = 'auto') -> tuple[bool, np.ndarray, dict[str, float]]:
    """(within limits, lengths (6,), smallest margin of each kind) of one pose a_T_b.

    The numbers of :func:`rrps_kinematics.limits.margins` (``Margins.minimum``, ``ok``), from a
    numba kernel when available (a few microseconds). ``quaternion_xyzw`` must be unit.
    """
    p = np.ascontiguousarray(position, dtype=float)
    q = np.ascontiguousarray(quaternion_xyzw, dtype=float)
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


def check_fresh(stamp: float, now: float, timeout: float) -> float:
    """Age [s] of a command stamped ``stamp`` at time ``now``; RejectedCommand if > timeout.

    A zero stamp (unset) is rejected: its age cannot be checked, so it may be stale. A stamp
    slightly in the future (clock offset between machines) is accepted.
    """
    if stamp == 0.0:
        raise RejectedCommand('command is unstamped (header.stamp = 0): its age cannot be checked')
    age = now - stamp
    if not math.isfinite(age) or age > timeout:
        raise RejectedCommand(f'command is stale: {age:.3f} s old > timeout {timeout:.3f} s')
    return age


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
