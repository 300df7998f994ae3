"""The simulated parallel master robot (§3.1): :class:`MasterModel` moves the master's pose a_T_b
(frame master_ring_a) towards a target within its speed limits, stopping on its own limits as
mechanical stops would (its ``lengths`` are what the encoders report); :func:`scripted_pose`."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import validate_pose
from rrps_description.rotations import quat_multiply_xyzw, rotation_angle_between, rotation_vector_to_quat_xyzw
from rrps_kinematics import check_pose, inverse_kinematics
from rrps_kinematics.limits import pose_margins
from rrps_teleop.guards import pose_step
from rrps_teleop.teleop_config import validate_scale

__all__ = ['TRAJECTORIES', 'scripted_pose', 'HandleMotion', 'HandleStep', 'MasterModel']

TRAJECTORIES = ('none', 'circle', 'lissajous')
#: Halvings of the step when a target lies outside the limits (boundary found to 2^-12 of a step).
BOUNDARY_BISECTIONS = 12


def scripted_pose(kind: str, t: float, home_position, home_quaternion_xyzw, *, amplitude: float,
                  period: float, angular_amplitude: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Pose of the scripted trajectory ``kind`` at time ``t`` [s] around the home pose, ω = 2π/period:
    ``circle`` p = home + A (cos ωt, sin ωt, 0); ``lissajous`` p = home + A (sin ωt, sin 2ωt, ½ sin 3ωt),
    turned by the rotation vector α (sin 2ωt, sin ωt, ½ sin 3ωt) in master_ring_a's frame."""
    if kind not in TRAJECTORIES:
        raise ValueError(f'trajectory must be one of {TRAJECTORIES}, got {kind!r}')
    period = validate_scale(period, 'period')
    if not (math.isfinite(amplitude) and amplitude >= 0.0):
        raise ValueError(f'amplitude must be finite and >= 0, got {amplitude!r}')
    if not (math.isfinite(angular_amplitude) and angular_amplitude >= 0.0):
        raise ValueError(f'angular_amplitude must be finite and >= 0, got {angular_amplitude!r}')
    p0 = np.asarray(home_position, dtype=float)
    q0 = np.asarray(home_quaternion_xyzw, dtype=float)
    w = 2.0 * math.pi / period
    if kind == 'none':
        return p0.copy(), q0.copy()
    if kind == 'circle':
        return p0 + amplitude * np.array([math.cos(w * t), math.sin(w * t), 0.0]), q0.copy()
    s1, s2, s3 = math.sin(w * t), math.sin(2.0 * w * t), 0.5 * math.sin(3.0 * w * t)
    p = p0 + amplitude * np.array([s1, s2, s3])
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(angular_amplitude * np.array([s2, s1, s3])), q0)
    return p, q


# Within these of its target the handle counts as there [m, rad].
AT_TARGET_POSITION = 1e-12
AT_TARGET_ANGLE = 1e-9


class HandleMotion(enum.Enum):
    """How far one step of the handle went towards its target."""

    FULL = 'full'                          # the whole step (or already at the target)
    SPEED_LIMITED = 'speed limited'        # shortened to the speed limits
    STOPPED = 'stopped at the limits'      # stopped where the master's own limits are


@dataclass(frozen=True)
class HandleStep:
    """The outcome of :meth:`MasterModel.move_toward`: the ``motion`` and, when the handle
    stopped at its limits, the limit in words (``reason``)."""

    motion: HandleMotion
    reason: str = ''

    def __str__(self) -> str:
        if self.motion is HandleMotion.FULL:
            return ''
        return self.motion.value + (f': {self.reason}' if self.reason else '')


class MasterModel:
    """The master's pose, moved towards targets within its speed and its own limits."""

    def __init__(self, geometry: RobotGeometry, *, max_linear_speed: float = 0.05,
                 max_angular_speed: float = 1.0):
        self.geometry = geometry
        self.max_linear_speed = validate_scale(max_linear_speed, 'max_linear_speed')
        self.max_angular_speed = validate_scale(max_angular_speed, 'max_angular_speed')
        ok, reason, _ = check_pose(geometry, geometry.home_position, geometry.home_quaternion_xyzw)
        if not ok:
            raise ValueError(f'{geometry.name}: home pose outside its limits ({reason})')
        self.position = np.array(geometry.home_position, dtype=float)
        self.quaternion_xyzw = np.array(geometry.home_quaternion_xyzw, dtype=float)
        self.lengths = inverse_kinematics(geometry, self.position, self.quaternion_xyzw).lengths.copy()

    def move_toward(self, position, quaternion_xyzw, dt: float) -> HandleStep:
        """Move at most one speed-limited step of ``dt`` s towards the target; stop at the limits.

        Returns how far the step went (:class:`HandleStep`). Raises ValueError for a malformed
        target (NaN, non-unit quaternion).
        """
        p1, q1 = validate_pose(position, quaternion_xyzw, what='master target')
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f'dt must be finite and >= 0, got {dt!r}')
        p0, q0 = self.position, self.quaternion_xyzw
        dp = float(np.linalg.norm(p1 - p0))
        dth = rotation_angle_between(q0, q1)
        if dp < AT_TARGET_POSITION and dth < AT_TARGET_ANGLE:
            return HandleStep(HandleMotion.FULL)  # at the target (checked when reached)
        fraction, note = 1.0, HandleStep(HandleMotion.FULL)
        limit = min(self.max_linear_speed * dt / dp if dp > 0 else math.inf,
                    self.max_angular_speed * dt / dth if dth > 0 else math.inf)
        if limit < 1.0:
            fraction, note = limit, HandleStep(HandleMotion.SPEED_LIMITED)
        p, q = pose_step(p0, q0, p1, q1, fraction)
        m = pose_margins(self.geometry, p, q)  # the compiled check
        if not m.ok:
            reason = check_pose(self.geometry, p, q)[1]  # which limit, in words (once)
            # Bisect for the furthest feasible fraction: the current pose is feasible.
            lo, hi = 0.0, fraction
            for _ in range(BOUNDARY_BISECTIONS):
                mid = 0.5 * (lo + hi)
                if pose_margins(self.geometry, *pose_step(p0, q0, p1, q1, mid)).ok:
                    lo = mid
                else:
                    hi = mid
            p, q = pose_step(p0, q0, p1, q1, lo)
            m = pose_margins(self.geometry, p, q)
            note = HandleStep(HandleMotion.STOPPED, reason)
        self.position, self.quaternion_xyzw = p, q
        self.lengths = m.lengths.copy()
        return note
