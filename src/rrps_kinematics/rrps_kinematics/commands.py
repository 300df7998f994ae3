"""Validation of command streams shared by the nodes: target poses, staleness, velocity limits.

Pure NumPy, no ROS import. Every check raises :class:`RejectedCommand` (a ValueError) with a
message that says why, so a node can keep its last safe command and report the reason::

    target = validate_target(geom, position, quaternion_xyzw, frame_id='ring_a')
    target.lengths, target.margins          # IK lengths (6,) [m] and every signed margin
    check_fresh(stamp_s, now_s, timeout)     # raises when the command is older than timeout
    limit_velocity(current, desired, max_speed, dt)   # joint-space step within max_speed
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import RobotGeometry
from .inverse import inverse_kinematics
from .limits import Margins, margins

__all__ = ['RejectedCommand', 'ValidTarget', 'validate_target', 'check_fresh', 'limit_velocity']


class RejectedCommand(ValueError):
    """A command that must not be acted on; the message says why."""


@dataclass(frozen=True)
class ValidTarget:
    """A target pose a_T_b that passed every check: unit quaternion, lengths, margins."""

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    lengths: np.ndarray
    margins: Margins


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
    m = margins(geometry, inverse_kinematics(geometry, p, q))
    if not m.ok:
        raise RejectedCommand(f'pose outside the limits: {m.reason}')
    return ValidTarget(position=p, quaternion_xyzw=q, lengths=np.array(m.lengths), margins=m)


def check_fresh(stamp: float, now: float, timeout: float) -> float:
    """Age [s] of a command stamped ``stamp`` at time ``now``; RejectedCommand if > timeout.

    A zero stamp (unset) counts as sent now. A stamp slightly in the future (clock offset
    between machines) is accepted.
    """
    if stamp == 0.0:
        return 0.0
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
