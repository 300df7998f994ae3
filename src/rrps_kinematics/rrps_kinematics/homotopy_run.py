"""The 40 homotopy paths (:mod:`.homotopy`) from the shipped generic system (:mod:`.study_start`) to
a robot's FK system, in characteristic lengths, and the real poses at their ends: scaled to e.e = 1,
imaginary part below ``IMAG_TOLERANCE``, A_c from e and r = g e* (docs/assembly_modes.md)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics import study_start
from rrps_kinematics.homotopy import DIVERGED, FAILED_STEP, TRACKED, track_all

__all__ = ['Endpoints', 'GAMMAS', 'IMAG_TOLERANCE', 'PATHS', 'SHARED_END', 'end_points', 'real_endpoints',
           'study_parameters']

PATHS = len(study_start.SOLUTIONS)
IMAG_TOLERANCE = 1e-7
#: Tracker settings: smallest and largest step in t, most steps per path, corrector tolerance.
MIN_STEP, MAX_STEP, MAX_STEPS, TOLERANCE = 1e-9, 0.2, 1000, 1e-10
#: Status of paths whose endpoints coincide (relative distance <= SAME_END): counted as failed.
SHARED_END, SAME_END = 4, 1e-8
#: How far below the least |e.e| / |x|^2 of a real pose a path counts as diverged (:func:`end_points`).
DIVERGED_MARGIN = 1e-6
#: The gamma of the homotopy, then two others (fixed, arbitrary) tried when a path fails: a path
#: that passes close to a point where solutions meet or leave to e.e = 0 fails for one gamma
#: (about one robot in ten), and the whole homotopy is then tracked again with the next.
GAMMAS = (study_start.GAMMA, 0.6 + 0.8j, -0.3 + 0.95j)


@dataclass(frozen=True)
class Endpoints:
    """Real poses at the paths' ends ((M, 3) [m], (M, 4) xyzw with w >= 0) and the paths' record:
    ``status`` (40,) (a :mod:`.homotopy` status code), ``steps`` (40,), ``failed`` the number of
    paths that neither reached t = 1 nor diverged, ``diverged`` those that went to e.e = 0
    (no pose), ``ends`` (40, 8) the complex endpoints (or where a path stopped), ``attempts`` the
    number of gammas tried (the record is that of the last)."""

    positions: np.ndarray
    quaternions_xyzw: np.ndarray
    status: np.ndarray
    steps: np.ndarray
    ends: np.ndarray
    attempts: int

    @property
    def failed(self) -> int:
        return int(np.sum((self.status != TRACKED) & (self.status != DIVERGED)))

    @property
    def diverged(self) -> int:
        return int(np.sum(self.status == DIVERGED))


def study_parameters(geometry: RobotGeometry, lengths: np.ndarray) -> np.ndarray:
    """The (6, 7) complex parameters (a_i, b_i, L_i^2) of the robot's system, in units of the
    characteristic length."""
    scale = geometry.characteristic_length
    P = np.zeros((6, 7), dtype=np.complex128)
    P[:, :3] = geometry.ring_a_anchors / scale
    P[:, 3:6] = geometry.ring_b_anchors / scale
    P[:, 6] = (np.asarray(lengths, dtype=float) / scale) ** 2
    return P


def end_points(P1: np.ndarray, gamma: complex) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Track the 40 shipped solutions to the system P1 with ``gamma``: (ends (40, 8), status, steps).
    Two paths ending at one point are both SHARED_END; a path is DIVERGED below |e.e| / |x|^2 =
    DIVERGED_MARGIN / (1 + R^2), which no real pose reaches (docs/assembly_modes.md, 'Homotopy')."""
    radius = np.max(np.linalg.norm(P1[:, :3], axis=1)
                    + np.linalg.norm(P1[:, 3:6], axis=1) + np.sqrt(np.abs(P1[:, 6])))
    X = study_start.SOLUTIONS.copy()
    status = np.zeros(PATHS, dtype=np.int64)
    reached = np.zeros(PATHS)
    steps = np.zeros(PATHS, dtype=np.int64)
    track_all(X, study_start.PARAMETERS, np.ascontiguousarray(P1, dtype=np.complex128), gamma, study_start.CHART,
              MIN_STEP, MAX_STEP, MAX_STEPS, TOLERANCE, DIVERGED_MARGIN / (1.0 + radius ** 2), status, reached, steps)
    ok = (status == TRACKED) & np.all(np.isfinite(X), axis=1)
    status[(status == TRACKED) & ~ok] = FAILED_STEP
    ends = X[ok]
    distance = np.linalg.norm(ends[:, None, :] - ends[None, :, :], axis=2)
    np.fill_diagonal(distance, np.inf)
    shared = np.min(distance, axis=1, initial=np.inf) <= SAME_END * (1.0 + np.linalg.norm(ends, axis=1))
    status[np.flatnonzero(ok)[shared]] = SHARED_END
    return X, status, steps


def real_endpoints(geometry: RobotGeometry, lengths: np.ndarray) -> Endpoints:
    """The real poses at the ends of the 40 paths for ``lengths`` (6,) (checked by the caller):
    tracked with each of GAMMAS in turn until no path fails."""
    P1 = study_parameters(geometry, lengths)
    for attempt, gamma in enumerate(GAMMAS, 1):
        X, status, steps = end_points(P1, gamma)
        if not np.any((status != TRACKED) & (status != DIVERGED)):
            break
    Y = X[status == TRACKED]
    ee = np.sum(Y[:, :4] ** 2, axis=1)
    Y = Y / np.sqrt(ee)[:, None]
    real = np.max(np.abs(Y.imag), axis=1) <= IMAG_TOLERANCE * np.linalg.norm(Y, axis=1)
    Y = Y[real].real
    e, g = Y[:, :4], Y[:, 4:]
    e_conj = e * np.array([1.0, -1.0, -1.0, -1.0])
    r = _vector_product(g, e_conj) * geometry.characteristic_length
    q = np.concatenate([e[:, 1:], e[:, :1]], axis=1)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.where(q[:, 3:] < 0.0, -1.0, 1.0)
    return Endpoints(r, q, status, steps, X, attempt)


def _vector_product(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Vector part of the quaternion products p q, (n, 4) (w, x, y, z) -> (n, 3)."""
    w1, v1 = p[:, :1], p[:, 1:]
    w2, v2 = q[:, :1], q[:, 1:]
    return w1 * v2 + w2 * v1 + np.cross(v1, v2)
