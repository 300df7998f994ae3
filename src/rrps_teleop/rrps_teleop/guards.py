"""A guarded teleop command, and the pose a fraction of the way between two poses; the guarded steps
themselves are the kernels of :mod:`rrps_teleop.compiled_guards`.
"""

from __future__ import annotations

import numpy as np

from rrps_kinematics.backend import kernels_of
from rrps_kinematics.limits import PoseMargins
from rrps_teleop.command_layout import (
    INTERFERENCE,
    INVERSE_CONDITION,
    LENGTHS,
    QUATERNION,
    SPHERICAL,
    STROKE,
    UNIVERSAL,
)

__all__ = ['LEG_SPEED_ITERATIONS', 'CHECK_STARTS', 'pose_step', 'GuardedCommand']

#: Most re-scalings of a Cartesian step for the leg speed limit (leg lengths are not linear in it).
LEG_SPEED_ITERATIONS = 4
#: Where each checked margin starts in a command buffer (CHECK_* order; conditioning last).
CHECK_STARTS = (STROKE, UNIVERSAL, SPHERICAL, INTERFERENCE, INVERSE_CONDITION)


def pose_step(p0: np.ndarray, q0: np.ndarray, p1: np.ndarray, q1: np.ndarray,
              fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The pose a ``fraction`` of the way from (p0, q0) to (p1, q1): straight line, constant-axis
    rotation (the guards' kernel :func:`rrps_teleop.compiled_guards.interpolated_pose`)."""
    from rrps_teleop import compiled_guards
    kernels = kernels_of(compiled_guards)
    p0, q0, p1, q1 = (np.ascontiguousarray(v, dtype=float) for v in (p0, q0, p1, q1))
    p, q = np.empty(3), np.empty(4)
    kernels.interpolated_pose(p0, q0, p1, kernels.rotation_vector(q0, q1), float(fraction), p, q)
    return p, q


class GuardedCommand:
    """A guarded slave command: ring_b's pose in ring_a, the leg lengths and every margin there,
    held in one read-only float64 buffer (layout :mod:`rrps_teleop.command_layout`)."""

    __slots__ = ('buffer', 'min_conditioning')

    def __init__(self, buffer: np.ndarray, min_conditioning: float):
        buffer.flags.writeable = False
        self.buffer = buffer
        self.min_conditioning = float(min_conditioning)

    @classmethod
    def at(cls, position, quaternion, lengths, margins: PoseMargins,
           min_conditioning: float) -> GuardedCommand:
        """The command of a pose (p, q), its commanded lengths and its margins."""
        return cls(np.concatenate([position, quaternion, lengths, margins.stroke, margins.universal,
                                   margins.spherical, margins.interference,
                                   [margins.inverse_condition]]), min_conditioning)

    @property
    def position(self) -> np.ndarray:
        return self.buffer[0:QUATERNION]

    @property
    def quaternion(self) -> np.ndarray:
        return self.buffer[QUATERNION:LENGTHS]

    @property
    def lengths(self) -> np.ndarray:
        return self.buffer[LENGTHS:STROKE]

    @property
    def margins(self) -> PoseMargins:
        b = self.buffer
        inv_cond = float(b[INVERSE_CONDITION])
        return PoseMargins(b[LENGTHS:STROKE], b[STROKE:UNIVERSAL], b[UNIVERSAL:SPHERICAL],
                           b[SPHERICAL:INTERFERENCE], b[INTERFERENCE:INVERSE_CONDITION], inv_cond,
                           inv_cond - self.min_conditioning)
