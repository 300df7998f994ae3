"""A planned motion's path as a C² curve of its path parameter ``s`` [m]: what its timing differentiates.

``s`` is arc length plus ``characteristic_length`` times rotation angle; positions and quaternions
are cubic splines of ``s`` through every sample. The curve gives ring_b's twist per unit path speed
(ring_a's frame, as :mod:`rrps_loads.reduced`), so that twist = T1 ṡ, twist rate = T1 s̈ + T2 ṡ²,
and each leg's length (eq. 1) with L' and L''. No ROS import.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import (
    cross,
    matrix_to_quat_xyzw,
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    quat_xyzw_to_matrix,
    rotation_angle_between,
)

__all__ = ['PathCurve', 'path_metric', 'corner_pieces', 'CORNER_ANGLE']

#: Where the sampled path turns by more than this [rad] from one segment to the next, it has a
#: corner: the motion stops there (a facade climber's lift-off, slide and set-down).
CORNER_ANGLE = np.radians(30.0)


def path_metric(path: np.ndarray, characteristic_length: float) -> np.ndarray:
    """The path parameter [m] at each sample (n,): arc length of the positions plus
    ``characteristic_length`` times the rotation angle, from 0."""
    angles = rotation_angle_between(path[:-1, :3, :3], path[1:, :3, :3])
    seg = np.linalg.norm(np.diff(path[:, :3, 3], axis=0), axis=1) + characteristic_length * angles
    return np.concatenate([[0.0], np.cumsum(seg)])


def corner_pieces(path: np.ndarray, characteristic_length: float) -> list[slice]:
    """The pieces of a sampled path between its corners (slices of its samples sharing their end
    samples): where consecutive segments, in positions and ``characteristic_length`` times the
    rotation vectors, turn by more than :data:`CORNER_ANGLE`."""
    steps = np.concatenate([np.diff(path[:, :3, 3], axis=0), characteristic_length * np.array(
        [_rotation_vector(a.T @ b) for a, b in zip(path[:-1, :3, :3], path[1:, :3, :3])]).reshape(-1, 3)], axis=1)
    norms = np.linalg.norm(steps, axis=1)
    moving = np.flatnonzero(norms > 1e-12)
    cuts = [0]
    for i, j in zip(moving[:-1], moving[1:]):
        cosine = steps[i] @ steps[j] / (norms[i] * norms[j])
        if cosine < np.cos(CORNER_ANGLE):
            cuts.append(int(j))
    cuts.append(len(path) - 1)
    return [slice(a, b + 1) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def _rotation_vector(R: np.ndarray) -> np.ndarray:
    angle = float(rotation_angle_between(np.eye(3), R))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    n = np.linalg.norm(axis)
    return axis / n * angle if n > 1e-15 else np.zeros(3)


class PathCurve:
    """A motion's path (n, 4, 4) and ring angles (n, 2) as a C² curve of ``s`` in [0, length]."""

    def __init__(self, path: np.ndarray, ring_angles: np.ndarray, *, characteristic_length: float):
        path = np.asarray(path, dtype=float)
        ring_angles = np.asarray(ring_angles, dtype=float)
        if path.ndim != 3 or path.shape[1:] != (4, 4) or len(path) < 1:
            raise ValueError(f'path must be (n, 4, 4), got {path.shape}')
        if ring_angles.shape != (len(path), 2):
            raise ValueError(f'ring_angles must be ({len(path)}, 2), got {ring_angles.shape}')
        s = path_metric(path, characteristic_length)
        kept = np.concatenate([[0], 1 + np.flatnonzero(np.diff(s) > 1e-12)])  # repeated poses once
        self.samples = s[kept]
        self.length = float(self.samples[-1])
        q = matrix_to_quat_xyzw(path[kept, :3, :3])
        flips = np.concatenate([[False], np.sum(q[1:] * q[:-1], axis=1) < 0.0])
        q = q * np.where(np.logical_xor.accumulate(flips), -1.0, 1.0)[:, None]
        self._first = (path[0, :3, 3].copy(), q[0].copy())
        self._angles = ring_angles[kept]
        y = np.concatenate([path[kept, :3, 3], q], axis=1)
        self._spline = CubicSpline(self.samples, y, axis=0) if len(kept) >= 2 else None

    def _y(self, s, order: int) -> np.ndarray:
        s = np.clip(np.atleast_1d(np.asarray(s, dtype=float)), 0.0, self.length)
        if self._spline is None:
            return (np.tile(np.concatenate(self._first), (len(s), 1)) if order == 0
                    else np.zeros((len(s), 7)))
        return self._spline(s, order)

    def poses(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Positions (K, 3) [m] and unit quaternions (K, 4) (x, y, z, w) of a_T_b at ``s`` (K,)."""
        y = self._y(s, 0)
        return y[:, :3], y[:, 3:] / np.linalg.norm(y[:, 3:], axis=1, keepdims=True)

    def ring_angles(self, s) -> np.ndarray:
        """The extra-DOF angles (K, 2) [rad] at ``s``, linear between the samples."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if len(self.samples) < 2:
            return np.tile(self._angles[0], (len(s), 1))
        return np.column_stack([np.interp(s, self.samples, self._angles[:, i]) for i in range(2)])

    def twists(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(positions (K, 3), unit quaternions (K, 4), T1 (K, 6), T2 (K, 6)) at ``s`` (K,): ring_b's
        twist per unit path speed and its derivative along the path (module docstring)."""
        y, dy, ddy = (self._y(s, k) for k in range(3))
        q, dq, ddq = y[:, 3:], dy[:, 3:], ddy[:, 3:]
        conj = quat_conjugate_xyzw(q)
        norm_sq = np.sum(q * q, axis=1)[:, None]
        omega = 2.0 * quat_multiply_xyzw(dq, conj)[:, :3] / norm_sq
        omega_rate = (2.0 * quat_multiply_xyzw(ddq, conj)[:, :3]
                      - 2.0 * np.sum(q * dq, axis=1)[:, None] * omega) / norm_sq
        return (y[:, :3], q / np.sqrt(norm_sq), np.concatenate([dy[:, :3], omega], axis=1),
                np.concatenate([ddy[:, :3], omega_rate], axis=1))

    def leg_rates(self, geometry: RobotGeometry, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Leg lengths L (K, 6) [m] and their first and second derivatives along the path L', L''
        (K, 6) at ``s`` (eq. 1 differentiated: l = p + R b - a, L = |l|)."""
        p, q, T1, T2 = self.twists(s)
        r = np.einsum('kij,lj->kli', quat_xyzw_to_matrix(q), geometry.ring_b_anchors)   # R b (K, 6, 3)
        leg = p[:, None, :] + r - geometry.ring_a_anchors[None]
        L = np.linalg.norm(leg, axis=2)
        u = leg / L[..., None]
        w1, w2 = T1[:, None, 3:], T2[:, None, 3:]
        d1 = T1[:, None, :3] + cross(w1, r)
        d2 = T2[:, None, :3] + cross(w2, r) + cross(w1, cross(w1, r))
        L1 = np.sum(u * d1, axis=2)
        L2 = np.sum(u * d2, axis=2) + (np.sum(d1 * d1, axis=2) - L1 ** 2) / L
        return L, L1, L2
