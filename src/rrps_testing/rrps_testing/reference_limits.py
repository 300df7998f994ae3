"""An independent computation of a pose's limits for tests, from the anchors alone (eq. 1).

Nothing of rrps_kinematics is used (:func:`reference_margins`): joint-cone angles by arccos, leg distances by the
KKT candidates of a convex quadratic over the unit square, the inverse condition number of the unit-consistent
Jacobian by LAPACK's SVD."""

from __future__ import annotations

import itertools

import numpy as np

from rrps_testing.virtual_work import quaternion_matrix

__all__ = ['reference_margins', 'segment_distance', 'KINDS']

#: The limits in the order the workspace reports the first one broken.
KINDS = ('stroke', 'universal', 'spherical', 'interference', 'conditioning')


def _point_segment(x, a, b) -> float:
    d = b - a
    dd = float(d @ d)
    t = 0.0 if dd == 0.0 else min(max(float((x - a) @ d) / dd, 0.0), 1.0)
    return float(np.linalg.norm(x - (a + t * d)))


def segment_distance(p0, p1, q0, q1) -> float:
    """min |p0 + s (p1 - p0) - q0 - t (q1 - q0)| over s, t in [0, 1]."""
    p0, p1, q0, q1 = (np.asarray(v, dtype=float) for v in (p0, p1, q0, q1))
    candidates = [_point_segment(p0, q0, q1), _point_segment(p1, q0, q1),
                  _point_segment(q0, p0, p1), _point_segment(q1, p0, p1)]
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    M = np.array([[u @ u, -(u @ v)], [-(u @ v), v @ v]])
    if abs(np.linalg.det(M)) > 1e-12 * max(M[0, 0] * M[1, 1], 1e-300):
        s, t = np.linalg.solve(M, [-(u @ w), v @ w])
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            candidates.append(float(np.linalg.norm(w + s * u - t * v)))
    return min(candidates)


def _angle(u, v) -> np.ndarray:
    return np.arccos(np.clip(np.sum(u * v, axis=-1), -1.0, 1.0))


def reference_margins(geometry, position, quaternion_xyzw) -> dict[str, np.ndarray | float]:
    """Every signed margin of one pose a_T_b (as ``rrps_kinematics.limits.Margins`` defines them)
    and the quantities behind them: lengths, cone angles, leg distances, inverse condition."""
    g = geometry
    R = quaternion_matrix(np.asarray(quaternion_xyzw, dtype=float) / np.linalg.norm(quaternion_xyzw))
    A = np.asarray(g.ring_a_anchors, dtype=float)
    B = np.asarray(position, dtype=float) + np.asarray(g.ring_b_anchors, dtype=float) @ R.T
    legs = B - A
    lengths = np.linalg.norm(legs, axis=1)
    u = legs / lengths[:, None]
    universal_angles = _angle(u, np.asarray(g.ring_a_joint_axes))
    spherical_angles = _angle(-(u @ R), np.asarray(g.ring_b_joint_axes))
    distances = np.array([segment_distance(A[i], B[i], A[j], B[j])
                          for i, j in itertools.combinations(range(6), 2)])
    J = np.hstack([u, np.cross(B - np.asarray(position, dtype=float), u) / g.characteristic_length])
    if np.all(np.isfinite(J)):
        sv = np.linalg.svd(J, compute_uv=False)
        inverse_condition = float(sv[-1] / sv[0]) if sv[0] > 0.0 else 0.0
    else:
        inverse_condition = float('nan')
    return {'lengths': lengths, 'universal_angles': universal_angles, 'spherical_angles': spherical_angles,
            'distances': distances, 'inverse_condition': inverse_condition,
            'stroke': np.minimum(lengths - g.min_length, g.max_length - lengths),
            'universal': g.universal_max_angle - universal_angles,
            'spherical': g.spherical_max_angle - spherical_angles,
            'interference': distances - 2.0 * g.leg_radius,
            'conditioning': inverse_condition - g.min_conditioning}
