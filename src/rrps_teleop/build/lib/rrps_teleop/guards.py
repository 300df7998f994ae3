"""The teleop guards in NumPy: a guarded command and the guarded Cartesian and joint steps.

The reference of :mod:`rrps_teleop.compiled_guards` (which computes the same steps as one numba
kernel each) and the fallback without numba. A step goes from the last command ``prev`` towards
a mapped target and returns ``(outcome, limit, check, index, candidate)`` with the codes of
:mod:`rrps_teleop.command_layout`: the speed limits scale it, the deceleration bands near a
singularity or leg interference scale it further when it approaches them, and it is refused at
the first margin it makes negative (or, where already negative, smaller).
"""

from __future__ import annotations

import math

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import (
    normalize_quat,
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    quat_xyzw_to_rotation_vector,
    rotation_angle_between,
    rotation_vector_to_quat_xyzw,
)
from rrps_kinematics import forward_kinematics
from rrps_kinematics.limits import PoseMargins, pose_margins
from rrps_teleop.command_layout import (
    CHECK_CONDITIONING,
    INTERFERENCE,
    INVERSE_CONDITION,
    LENGTHS,
    LIMIT_COLLISION_DECELERATE,
    LIMIT_COLLISION_HALT,
    LIMIT_NONE,
    LIMIT_SINGULARITY_DECELERATE,
    LIMIT_SINGULARITY_HALT,
    LIMIT_SPEED,
    QUATERNION,
    SPEED_TOLERANCE,
    SPHERICAL,
    STEP_ACCEPTED,
    STEP_FK_FAILED,
    STEP_REFUSED,
    STEP_UNCHANGED,
    STROKE,
    UNIVERSAL,
)
from rrps_teleop.teleop_config import TeleopConfig

__all__ = ['LEG_SPEED_ITERATIONS', 'CHECK_STARTS', 'pose_step', 'GuardedCommand', 'ReferenceGuards']

#: Most re-scalings of a Cartesian step for the leg speed limit (leg lengths are not linear in it).
LEG_SPEED_ITERATIONS = 4
#: Where each checked margin starts in a command buffer (CHECK_* order; conditioning last).
CHECK_STARTS = (STROKE, UNIVERSAL, SPHERICAL, INTERFERENCE, INVERSE_CONDITION)


def pose_step(p0: np.ndarray, q0: np.ndarray, p1: np.ndarray, q1: np.ndarray,
              fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The pose a ``fraction`` of the way from (p0, q0) to (p1, q1): straight line, constant-axis rotation."""
    rv = quat_xyzw_to_rotation_vector(quat_multiply_xyzw(q1, quat_conjugate_xyzw(q0)))
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(fraction * rv), q0)
    return p0 + fraction * (p1 - p0), normalize_quat(q)


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


class ReferenceGuards:
    """The guarded steps of one slave robot under a :class:`TeleopConfig`; ``halt`` is the
    inverse condition number where motion towards a singularity halts."""

    def __init__(self, slave: RobotGeometry):
        self.slave = slave

    def _at_pose(self, p, q) -> GuardedCommand:
        m = pose_margins(self.slave, p, q, backend='numpy')
        return GuardedCommand.at(p, q, m.lengths, m, self.slave.min_conditioning)

    def _at_lengths(self, prev: GuardedCommand, lengths: np.ndarray) -> GuardedCommand | None:
        fk = forward_kinematics(self.slave, lengths, prev.position, prev.quaternion, backend='numpy')
        if not fk.converged:
            return None
        m = pose_margins(self.slave, fk.position, fk.quaternion_xyzw, backend='numpy')
        return GuardedCommand.at(fk.position, fk.quaternion_xyzw, lengths, m, self.slave.min_conditioning)

    def cartesian_step(self, prev: GuardedCommand, p1, q1, dt: float, config: TeleopConfig, halt: float):
        """The guarded step from ``prev`` towards the pose (p1, q1) over ``dt`` s."""
        c = config
        dp = float(np.linalg.norm(p1 - prev.position))
        dth = rotation_angle_between(prev.quaternion, q1)
        if dp < 1e-12 and dth < 1e-12:
            return STEP_UNCHANGED, LIMIT_NONE, -1, -1, prev
        fraction, limit = 1.0, LIMIT_NONE
        bound = min(c.max_linear_speed * dt / dp if dp > 0 else math.inf,
                    c.max_angular_speed * dt / dth if dth > 0 else math.inf)
        if bound < 1.0 - SPEED_TOLERANCE:
            fraction, limit = bound, LIMIT_SPEED
        cand = self._at_pose(*pose_step(prev.position, prev.quaternion, p1, q1, fraction))
        leg_limit = self.slave.max_speed * dt
        for _ in range(LEG_SPEED_ITERATIONS):  # lengths are nearly linear in the fraction: 1-2 passes
            leg_step = float(np.max(np.abs(cand.lengths - prev.lengths)))
            if leg_step <= leg_limit * (1.0 + SPEED_TOLERANCE):
                break
            fraction *= leg_limit / leg_step * (1.0 - 1e-9)
            limit = LIMIT_SPEED
            cand = self._at_pose(*pose_step(prev.position, prev.quaternion, p1, q1, fraction))
        factor, slow = deceleration(prev.margins, cand.margins, c, halt)
        if factor < 1.0:
            fraction *= factor
            limit = slow
            cand = self._at_pose(*pose_step(prev.position, prev.quaternion, p1, q1, fraction))
        return refusal(prev, cand, limit, halt)

    def joint_step(self, prev: GuardedCommand, L1, dt: float, config: TeleopConfig, halt: float):
        """The guarded step from ``prev`` towards the leg lengths ``L1`` over ``dt`` s."""
        dL = L1 - prev.lengths
        largest = float(np.max(np.abs(dL)))
        if largest < 1e-12:
            return STEP_UNCHANGED, LIMIT_NONE, -1, -1, prev
        fraction, limit = 1.0, LIMIT_NONE
        if largest > self.slave.max_speed * dt * (1.0 + SPEED_TOLERANCE):
            fraction, limit = self.slave.max_speed * dt / largest, LIMIT_SPEED
        cand = self._at_lengths(prev, prev.lengths + fraction * dL)
        if cand is None:
            return STEP_FK_FAILED, limit, -1, -1, prev
        factor, slow = deceleration(prev.margins, cand.margins, config, halt)
        if factor < 1.0:
            fraction *= factor
            limit = slow
            cand = self._at_lengths(prev, prev.lengths + fraction * dL)
            if cand is None:
                return STEP_FK_FAILED, limit, -1, -1, prev
        return refusal(prev, cand, limit, halt)


def deceleration(before: PoseMargins, after: PoseMargins, config: TeleopConfig, halt: float) -> tuple[float, int]:
    """Step scale in [0, 1] near a singularity or interference, when the step approaches it."""
    c = config
    factor, limit = 1.0, LIMIT_NONE
    c0, c1 = float(before.inverse_condition), float(after.inverse_condition)
    if c1 < c0 and c0 < c.singularity_slowdown:
        f = min(max((c0 - halt) / (c.singularity_slowdown - halt), 0.0), 1.0)
        if f < factor:
            factor = f
            limit = LIMIT_SINGULARITY_DECELERATE if f > 0.0 else LIMIT_SINGULARITY_HALT
    d0, d1 = float(np.min(before.interference)), float(np.min(after.interference))
    if d1 < d0 and d0 < c.collision_slowdown:
        f = min(max(d0 / c.collision_slowdown, 0.0), 1.0)
        if f < factor:
            factor = f
            limit = LIMIT_COLLISION_DECELERATE if f > 0.0 else LIMIT_COLLISION_HALT
    return factor, limit


def refusal(prev: GuardedCommand, cand: GuardedCommand, limit: int, halt: float):
    """The step's outcome: refused at the first margin it makes negative (or, where already
    negative, smaller), else accepted."""
    old, new = prev.buffer, cand.buffer
    for check, start in enumerate(CHECK_STARTS):
        if check == CHECK_CONDITIONING:
            n, o = new[start:start + 1] - halt, old[start:start + 1] - halt
        else:
            n, o = new[start:CHECK_STARTS[check + 1]], old[start:CHECK_STARTS[check + 1]]
        worse = ~(n >= 0.0) & ~(n >= o)
        if np.any(worse):
            return STEP_REFUSED, limit, check, int(np.flatnonzero(worse)[0]), cand
    return STEP_ACCEPTED, limit, -1, -1, cand
