"""Validation of target poses and joint-space velocity limits of command streams (no ROS).

Every check raises :class:`InvalidTarget` (a ValueError) saying why, so a node can keep its last
safe command (:func:`validate_target`, :func:`pose_limits`, :func:`limit_velocity`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.backend import interpreted, use_numba
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.limits import limit_arrays, margins

__all__ = ['InvalidTarget', 'ValidTarget', 'validate_target', 'pose_limits', 'limit_velocity']

MARGIN_KINDS = ('stroke', 'universal', 'spherical', 'interference', 'conditioning')
def pose_limits(geometry: RobotGeometry, position, quaternion_xyzw, *,
                backend: str = 'auto') -> tuple[bool, np.ndarray, dict[str, float]]:
    """(within limits, lengths (6,), smallest margin of each kind) of one pose a_T_b.

    The numbers of :func:`rrps_kinematics.limits.margins` (``Margins.minimum``, ``ok``), from its
    kernel for one pose (a few microseconds compiled). ``quaternion_xyzw`` must be unit.
    """
    from rrps_kinematics.compiled_limits import N_MARGINS, pose_margins
    # fresh writable copies: the kernel is compiled for one argument type only (a read-only array,
    # e.g. a robot's home quaternion, would be another type and compile again on first use)
    p = np.array(position, dtype=float)
    q = np.array(quaternion_xyzw, dtype=float)
    if use_numba(backend):
        out = np.empty(N_MARGINS)
        lengths = np.empty(6)
        pose_margins(limit_arrays(geometry), p, q, out, lengths)
    else:
        out, lengths = [0.0] * N_MARGINS, [0.0] * 6
        interpreted(pose_margins)(limit_arrays(geometry, lists=True), p.tolist(), q.tolist(), out, lengths)
        out, lengths = np.array(out), np.array(lengths)
    minimum = dict(zip(MARGIN_KINDS, (float(v) for v in out[:5])))
    ok = bool(np.all(out[:5] >= 0.0) and out[5] > 0.0)
    return ok, lengths, minimum


class InvalidTarget(ValueError):
    """A target pose that must not be acted on; the message says why."""


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
        raise InvalidTarget(f"frame_id is {frame_id!r}, expected {expected_frame!r}")
    p = np.asarray(position, dtype=float)
    q = np.asarray(quaternion_xyzw, dtype=float)
    if p.shape != (3,) or q.shape != (4,):
        raise InvalidTarget(f'pose must be a position (3,) and a quaternion (4,), got '
                              f'{p.shape} and {q.shape}')
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise InvalidTarget('pose contains NaN or infinite values')
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > quaternion_tolerance:
        raise InvalidTarget(f'quaternion norm {norm:.6g} is not 1 (tolerance {quaternion_tolerance:g})')
    q = q / norm
    ok, lengths, minimum = pose_limits(geometry, p, q)
    if not ok:  # word the reason (every margin of the pose)
        reason = margins(geometry, inverse_kinematics(geometry, p, q)).reason
        raise InvalidTarget(f'pose outside the limits: {reason}')
    return ValidTarget(position=p, quaternion_xyzw=q, lengths=lengths, minimum=minimum)



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
