"""Timing a planned motion phase: its path streamed at a speed, sampled at any time.

A motion phase of a gait plan (``rrps_climbing.gait``) is a polyline of ring_b poses a_T_b with
the extra-DOF angles of both rings at each sample. Streaming it at ``speed`` gives each sample a
time: the arc length of positions plus ``characteristic_length`` times the rotation angle, over
the speed. Between samples positions and angles are interpolated linearly and rotations by
normalised linear interpolation of their quaternions (the samples are close).
"""

from __future__ import annotations

import numpy as np

from rrps_description.pose import Pose
from rrps_description.rotations import matrix_to_quat_xyzw, rotation_angle_between

__all__ = ['PhasePath']


class PhasePath:
    """A phase's path (n, 4, 4) and ring angles (n, 2), timed at ``speed`` [m/s]."""

    def __init__(self, path: np.ndarray, ring_angles: np.ndarray, *, speed: float,
                 characteristic_length: float):
        self.path = np.asarray(path, dtype=float)
        self.ring_angles = np.asarray(ring_angles, dtype=float)
        if self.path.ndim != 3 or self.path.shape[1:] != (4, 4) or len(self.path) < 1:
            raise ValueError(f'path must be (n, 4, 4), got {self.path.shape}')
        if self.ring_angles.shape != (len(self.path), 2):
            raise ValueError(f'ring_angles must be ({len(self.path)}, 2), got {self.ring_angles.shape}')
        if not speed > 0.0:
            raise ValueError(f'speed must be > 0, got {speed!r}')
        p = self.path[:, :3, 3]
        angles = rotation_angle_between(self.path[:-1, :3, :3], self.path[1:, :3, :3])
        seg = np.linalg.norm(np.diff(p, axis=0), axis=1) + characteristic_length * angles
        self.times = np.concatenate([[0.0], np.cumsum(seg)]) / speed
        #: the samples' rotations as quaternions (n, 4), x, y, z, w
        self.quaternions_xyzw = matrix_to_quat_xyzw(self.path[:, :3, :3])

    @property
    def duration(self) -> float:
        """Time [s] to stream the whole path."""
        return float(self.times[-1])

    def at(self, t: float) -> tuple[Pose, np.ndarray]:
        """The planned a_T_b and ring angles (theta_a, theta_b) at time ``t`` [s] of the phase."""
        times = self.times
        if t >= times[-1]:
            return Pose.from_matrix(self.path[-1]), self.ring_angles[-1]
        k = max(int(np.searchsorted(times, t, side='right')) - 1, 0)
        w = (t - times[k]) / max(times[k + 1] - times[k], 1e-12)
        p = (1 - w) * self.path[k, :3, 3] + w * self.path[k + 1, :3, 3]
        q0, q1 = self.quaternions_xyzw[k], self.quaternions_xyzw[k + 1]
        q1 = q1 if q0 @ q1 >= 0 else -q1
        return Pose(p, (1 - w) * q0 + w * q1), (1 - w) * self.ring_angles[k] + w * self.ring_angles[k + 1]
