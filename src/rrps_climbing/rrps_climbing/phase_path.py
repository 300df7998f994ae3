"""A timed motion phase as a stream plays it: its samples (time, pose a_T_b, ring angles), any time.

Between samples: linear interpolation, nlerp for rotations. :class:`PlayClock` plays the path in
time: a late tick takes the sample of its time; a brake slows the play to rest
(:mod:`.path_brake`).
"""

from __future__ import annotations

import numpy as np

from rrps_climbing.path_brake import PathBrake
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_angle_between

__all__ = ['PhasePath', 'PlayClock', 'MAX_TICK_PERIODS']

#: Most periods one tick advances a stream (a stall does not leap along the path).
MAX_TICK_PERIODS = 5


class PhasePath:
    """Samples at ``times`` (n,) [s] from 0: ``positions`` (n, 3) [m], unit ``quaternions_xyzw``
    (n, 4) and ``ring_angles`` (n, 2) [rad]."""

    def __init__(self, times, positions, quaternions_xyzw, ring_angles):
        self.times = np.asarray(times, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        self.quaternions_xyzw = np.asarray(quaternions_xyzw, dtype=float)
        self.ring_angles = np.asarray(ring_angles, dtype=float)
        n = len(self.times)
        if self.times.ndim != 1 or n < 1 or self.times[0] != 0.0 or np.any(np.diff(self.times) <= 0.0):
            raise ValueError('times must be 1-D, from 0, increasing')
        for name, value, width in (('positions', self.positions, 3), ('quaternions_xyzw', self.quaternions_xyzw, 4),
                                   ('ring_angles', self.ring_angles, 2)):
            if value.shape != (n, width):
                raise ValueError(f'{name} must be ({n}, {width}), got {value.shape}')

    @property
    def duration(self) -> float:
        """Time [s] to stream the whole path."""
        return float(self.times[-1])

    def nearest(self, pose: Pose, until: float, position_scale: float, orientation_scale: float) -> float:
        """The time [s] of the sample, among those up to time ``until``, nearest ``pose``: the least
        position error over ``position_scale`` [m] plus orientation error over ``orientation_scale`` [rad]."""
        n = max(int(np.searchsorted(self.times, until, side='right')), 1)
        dp = np.linalg.norm(self.positions[:n] - np.asarray(pose.position), axis=1)
        da = rotation_angle_between(self.quaternions_xyzw[:n], np.asarray(pose.quaternion_xyzw, dtype=float))
        return float(self.times[np.argmin(dp / position_scale + da / orientation_scale)])

    def at(self, t: float) -> tuple[Pose, np.ndarray]:
        """The planned a_T_b and ring angles (theta_a, theta_b) at time ``t`` [s] of the phase."""
        times = self.times
        if t >= times[-1]:
            return Pose(self.positions[-1], self.quaternions_xyzw[-1]), self.ring_angles[-1]
        k = max(int(np.searchsorted(times, t, side='right')) - 1, 0)
        w = (t - times[k]) / (times[k + 1] - times[k])
        p = (1 - w) * self.positions[k] + w * self.positions[k + 1]
        q0, q1 = self.quaternions_xyzw[k], self.quaternions_xyzw[k + 1]
        q1 = q1 if q0 @ q1 >= 0 else -q1
        return Pose(p, (1 - w) * q0 + w * q1), (1 - w) * self.ring_angles[k] + w * self.ring_angles[k + 1]


class PlayClock:
    """Where a stream played every ``period`` [s] is in its path: each tick advances it by the time
    since the last tick (at most :data:`MAX_TICK_PERIODS` periods), the first one by one period;
    during a :meth:`brake`, by the braked time (:meth:`.path_brake.PathBrake.path_time`)."""

    def __init__(self, period: float):
        self.period, self.t = float(period), 0.0
        self._last: float | None = None
        self._brake: tuple[float, float, PathBrake] | None = None  # its start [s], path time then [s], profile

    def advance(self, now: float) -> float:
        """The path time [s] at a tick at ``now`` [s]."""
        if self._brake is not None:
            start, t0, brake = self._brake
            self._last, self.t = now, t0 + brake.path_time(now - start)
            return self.t
        step = self.period if self._last is None else min(max(now - self._last, 0.0), MAX_TICK_PERIODS * self.period)
        self._last, self.t = now, self.t + step
        return self.t

    def brake(self, brake: PathBrake) -> None:
        """From the last tick on, slow the play to rest along ``brake`` (none before a first tick)."""
        if self._last is not None and self._brake is None:
            self._brake = (self._last, self.t, brake)

    @property
    def braking(self) -> bool:
        """A brake is under way (its last tick is yet to come)."""
        return self._brake is not None and self._last - self._brake[0] < self._brake[2].duration

    def restart(self, at: float | None = None) -> None:
        """After a pause: the next tick advances one period (from path time ``at`` [s] if given)."""
        self._last, self._brake = None, None
        if at is not None:
            self.t = float(at)
