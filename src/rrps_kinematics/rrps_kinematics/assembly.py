"""All assembly modes: every real pose of ring_b for six given leg lengths (§2.2).

``'continuation'`` (default): parameter homotopy in Study coordinates from the 40 shipped generic
solutions (:mod:`.homotopy_run`), certified complete when every path ends; a failed path brings in
the multi-start. ``'multistart'``: damped Newton from a fixed Halton seed set (:func:`seed_poses`),
no proof of completeness; it also runs without numba. See docs/assembly_modes.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_angle_between
from rrps_kinematics.backend import use_numba
from rrps_kinematics.forward import check_lengths, forward_kinematics
from rrps_kinematics.inverse import inverse_kinematics

__all__ = ['AssemblyModes', 'METHODS', 'PATHS', 'assembly_modes', 'halton', 'seed_poses']

METHODS = ('continuation', 'multistart')
#: Homotopy paths: the generic number of complex FK solutions (:mod:`.study_start`).
PATHS = 40

_PRIMES = (2, 3, 5, 7, 11, 13)


def halton(n: int, dim: int = 6) -> np.ndarray:
    """The first n points (index 1..n) of the unscrambled Halton sequence in [0, 1)^dim."""
    if not 1 <= dim <= len(_PRIMES):
        raise ValueError(f'dim must be in 1..{len(_PRIMES)}, got {dim}')
    out = np.zeros((n, dim))
    for k, base in enumerate(_PRIMES[:dim]):
        i = np.arange(1, n + 1)
        f = 1.0
        while np.any(i > 0):
            f /= base
            out[:, k] += f * (i % base)
            i //= base
    return out


def seed_poses(geometry: RobotGeometry, lengths: np.ndarray, n_seeds: int) -> tuple[np.ndarray, np.ndarray]:
    """The multi-start's seeds: positions (n, 3), quaternions (n, 4) (docs/assembly_modes.md, 'Completeness')."""
    h = halton(n_seeds, 6)
    u1, u2, u3 = h[:, 0], h[:, 1], h[:, 2]
    Q = np.stack([np.sqrt(1 - u1) * np.sin(2 * np.pi * u2), np.sqrt(1 - u1) * np.cos(2 * np.pi * u2),
                  np.sqrt(u1) * np.sin(2 * np.pi * u3), np.sqrt(u1) * np.cos(2 * np.pi * u3)], axis=1)
    R = quat_xyzw_to_matrix(Q)
    centre = np.mean(geometry.ring_a_anchors - np.einsum('nkj,ij->nik', R, geometry.ring_b_anchors), axis=1)
    P = centre + (2.0 * h[:, 3:] - 1.0) * np.max(lengths)
    return P, Q


@dataclass(frozen=True)
class AssemblyModes:
    """The real FK solutions, nearest to the home pose first (docs/assembly_modes.md).

    ``residuals``: the IK check max |l - L| [m]; ``hits``: the seeds or paths that reached each
    mode. ``certified``: all 40 paths ended with one gamma, so no real mode is missing.
    """

    positions: np.ndarray
    quaternions_xyzw: np.ndarray
    residuals: np.ndarray
    hits: np.ndarray
    seeds: int
    method: str = 'multistart'
    certified: bool = False
    paths_failed: int = 0

    def __len__(self) -> int:
        return len(self.positions)


def assembly_modes(geometry: RobotGeometry, lengths, *, method: str = 'continuation', n_seeds: int = 20000,
                   tolerance: float = 1e-9, backend: str = 'auto') -> AssemblyModes:
    """All real poses a_T_b with actuator lengths ``lengths`` (6,), by ``method`` (module docstring).

    Each returned pose reproduces the lengths by inverse kinematics to ``tolerance`` [m]; two
    poses closer than 1e-6 (position / characteristic length + rotation angle) are one mode.
    Joint and stroke limits are not applied (see :func:`rrps_kinematics.margins`).
    """
    L = check_lengths(lengths)
    if L.shape != (6,):
        raise ValueError(f'lengths must have shape (6,), got {L.shape}')
    if np.any(L <= 0.0):
        raise ValueError('lengths must be positive')
    if method not in METHODS:
        raise ValueError(f'method must be one of {METHODS}, got {method!r}')
    if int(n_seeds) != n_seeds or n_seeds < 1:
        raise ValueError(f'n_seeds must be a positive integer, got {n_seeds!r}')
    if method == 'multistart' or not use_numba(backend):
        P, Q, res, hits = _multistart(geometry, L, int(n_seeds), tolerance, backend)
        return _modes(geometry, L, P, Q, res, hits, tolerance, seeds=int(n_seeds), method='multistart')
    from rrps_kinematics.homotopy_run import real_endpoints  # compiles with numba on first use
    ends = real_endpoints(geometry, L)
    fk = forward_kinematics(geometry, np.broadcast_to(L, (len(ends.positions), 6)), ends.positions,
                            ends.quaternions_xyzw, tolerance=1e-12, max_iterations=10, backend=backend)
    good = fk.converged | (fk.residual <= tolerance)
    P, Q, res = fk.position[good], fk.quaternion_xyzw[good], fk.residual[good]
    hits = np.ones(len(P), dtype=int)
    if ends.failed == 0:
        return _modes(geometry, L, P, Q, res, hits, tolerance, seeds=0, method=method, certified=True)
    Pm, Qm, resm, hitsm = _multistart(geometry, L, int(n_seeds), tolerance, backend)
    return _modes(geometry, L, np.vstack([P, Pm]), np.vstack([Q, Qm]), np.concatenate([res, resm]),
                  np.concatenate([hits, hitsm]), tolerance, seeds=int(n_seeds),
                  method='continuation+multistart', paths_failed=ends.failed)


def _multistart(geometry, L, n_seeds, tolerance, backend):
    """Converged Newton solves from the seed set: positions, quaternions, residuals, hits (1 each)."""
    P, Q = seed_poses(geometry, L, n_seeds)
    fk = forward_kinematics(geometry, np.broadcast_to(L, (len(P), 6)), P, Q, tolerance=1e-12,
                            max_iterations=60, backend=backend)
    # Converged to 1e-12, or stalled by round-off within the acceptance tolerance.
    good = fk.converged | (fk.residual <= tolerance)
    return fk.position[good], fk.quaternion_xyzw[good], fk.residual[good], np.ones(int(np.sum(good)), dtype=int)


def _modes(geometry, L, P, Q, res, hits_in, tolerance, **flags) -> AssemblyModes:
    """De-duplicate the solves (the most accurate member of each cluster stands for it, its
    hits summed), verify by IK, order nearest to home first."""
    scale = geometry.characteristic_length
    order = np.lexsort((Q[:, 0], P[:, 2], P[:, 1], P[:, 0]))
    P, Q, res, hits_in = P[order], Q[order], res[order], hits_in[order]
    positions, quats, hits = [], [], []
    remaining = np.arange(len(P))
    while remaining.size:
        p, q = P[remaining[0]], Q[remaining[0]]
        dot = np.minimum(1.0, np.abs(Q[remaining] @ q))
        same = (np.linalg.norm(P[remaining] - p, axis=1) / scale + 2.0 * np.arccos(dot)) < 1e-6
        best = remaining[same][np.argmin(res[remaining[same]])]  # the most accurate member
        positions.append(P[best])
        quats.append(Q[best])
        hits.append(int(np.sum(hits_in[remaining[same]])))
        remaining = remaining[~same]
    if not positions:
        return AssemblyModes(np.zeros((0, 3)), np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=int), **flags)
    positions, quats, hits = np.array(positions), np.array(quats), np.array(hits)
    residuals = np.max(np.abs(inverse_kinematics(geometry, positions, quats).lengths - L), axis=1)
    keep = residuals <= tolerance
    positions, quats, hits, residuals = positions[keep], quats[keep], hits[keep], residuals[keep]
    home_R = quat_xyzw_to_matrix(geometry.home_quaternion_xyzw)
    distance = (np.linalg.norm(positions - geometry.home_position, axis=1) / scale
                + rotation_angle_between(home_R, quat_xyzw_to_matrix(quats)))
    # Mirror-image modes lie at the same distance: ties broken by position, whatever the method.
    order = np.lexsort((positions[:, 2], positions[:, 1], positions[:, 0], np.round(distance, 9)))
    return AssemblyModes(positions[order], quats[order], residuals[order], hits[order], **flags)
