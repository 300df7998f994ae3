"""Limits of an RRPS pose as signed margins (positive = inside the limit, SI units).

One call gives every margin of a pose or a batch of poses, a ``within_limits`` flag and a
human-readable reason::

    from rrps_kinematics import inverse_kinematics, margins, check_pose
    ik = inverse_kinematics(geom, position, quaternion_xyzw)      # single pose or (N,3), (N,4)
    m = margins(geom, ik)
    m.ok                  # bool, or (N,) bool: every margin >= 0 (and the Jacobian not singular)
    m.violations()        # ['stroke: leg_3 length 0.5612 m > max_length 0.5500 m', ...]
    m.broken()            # the same as data: [LimitViolation(kind=LimitKind.STROKE, legs=(3,), ...)]
    ok, reason, m = check_pose(geom, position, quaternion_xyzw)   # single pose convenience

Fields (a single pose drops the leading N):

* ``stroke`` (N, 6) [m]: ``min(l_i - min_length, max_length - l_i)`` for the actuator lengths.
* ``universal`` (N, 6) [rad]: ``universal_max_angle`` minus the angle between leg i and the
  universal joint's neutral axis (``geometry.ring_a_joint_axes``).
* ``spherical`` (N, 6) [rad]: ``spherical_max_angle`` minus the angle between leg i (seen from
  ring_b, pointing to ring_a) and the spherical joint's neutral axis (``ring_b_joint_axes``).
* ``interference`` (N, 15) [m]: for every pair of legs (``PAIRS[k] = (i, j)``, zero-based),
  the minimum distance between the segments a_i -> B_i and a_j -> B_j (joint centre to joint
  centre, B in ring_a's frame) minus ``2 * leg_radius`` (the paper's Figure 8c interference).
* ``inverse_condition`` (N,): 1/cond of the unit-consistent inverse Jacobian: J's angular
  columns (units m) are divided by ``geometry.characteristic_length``, so all entries are
  dimensionless; 1 = isotropic, 0 = singular.
* ``conditioning`` (N,): ``inverse_condition - geometry.min_conditioning``.
* ``ok`` (N,) bool: all margins >= 0 and ``inverse_condition > 0``; NaN counts as a violation.

Pure NumPy, vectorised over the batch; no ROS import.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from itertools import combinations
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.backend import use_numba
from rrps_kinematics.inverse import InverseKinematicsResult, inverse_kinematics
from rrps_kinematics.jacobian import inverse_jacobian

__all__ = [
    'PAIRS',
    'PoseMargins',
    'pose_margins',
    'LimitArrays',
    'limit_arrays',
    'LimitKind',
    'LIMIT_KINDS',
    'LimitViolation',
    'Margins',
    'margins',
    'check_pose',
    'segment_distances',
    'inverse_condition_number',
]

#: The 15 leg pairs (i, j), i < j, zero-based, in the order of ``Margins.interference``.
PAIRS = np.array(list(combinations(range(6), 2)), dtype=int)
PAIRS.setflags(write=False)


class LimitKind(str, enum.Enum):
    """The limits of a pose, named as the margins' fields (a str: ``LimitKind.STROKE == 'stroke'``)."""

    STROKE = 'stroke'
    UNIVERSAL = 'universal'
    SPHERICAL = 'spherical'
    INTERFERENCE = 'interference'
    CONDITIONING = 'conditioning'


#: The limit kinds in their order of checking (margins, workspace, fixture).
LIMIT_KINDS = tuple(kind.value for kind in LimitKind)


@dataclass(frozen=True)
class LimitViolation:
    """One broken limit as data: its ``kind``, the ``legs`` involved (numbers 1..6; a pair for
    interference, none for conditioning), the ``value`` that broke it and the ``bound`` it
    broke, in SI units (a leg length [m], a joint angle [rad], the distance between two legs
    [m] against twice the leg radius, the inverse condition number). ``str()`` words it."""

    kind: LimitKind
    legs: tuple[int, ...]
    value: float
    bound: float

    def __str__(self) -> str:
        legs = [f'leg_{i}' for i in self.legs]
        if self.kind is LimitKind.STROKE:
            if not math.isfinite(self.value):
                return f'stroke: {legs[0]} length is not finite'
            side = '<' if self.value < self.bound else '>'
            name = 'min_length' if side == '<' else 'max_length'
            return f'stroke: {legs[0]} length {self.value:.4f} m {side} {name} {self.bound:.4f} m'
        if self.kind in (LimitKind.UNIVERSAL, LimitKind.SPHERICAL):
            return (f'{self.kind.value} joint: {legs[0]} angle {self.value:.3f} rad > '
                    f'{self.kind.value}_max_angle {self.bound:.3f} rad')
        if self.kind is LimitKind.INTERFERENCE:
            return (f'interference: {legs[0]} and {legs[1]} are {self.value:.4f} m apart < '
                    f'2 * radius {self.bound:.4f} m')
        return (f'conditioning: inverse condition number {self.value:.4f} < min_conditioning '
                f'{self.bound:.4f} (near a singularity)')


class LimitArrays(NamedTuple):
    """A robot's limits as contiguous arrays, the one argument of the compiled guards (numba
    takes a NamedTuple of arrays): anchors (6, 3) [m], joint neutral axes (6, 3), and
    ``limits`` = [min_length, max_length, universal_max_angle, spherical_max_angle, leg_radius,
    characteristic_length, min_conditioning] (SI units)."""

    ring_a_anchors: np.ndarray
    ring_b_anchors: np.ndarray
    ring_a_joint_axes: np.ndarray
    ring_b_joint_axes: np.ndarray
    limits: np.ndarray


_limit_arrays: dict[int, tuple[RobotGeometry, LimitArrays]] = {}


def limit_arrays(geometry: RobotGeometry) -> LimitArrays:
    """The :class:`LimitArrays` of ``geometry`` (built once per geometry object)."""
    entry = _limit_arrays.get(id(geometry))
    arrays = entry[1] if entry is not None and entry[0] is geometry else None
    if arrays is None:
        g = geometry
        arrays = LimitArrays(*(np.ascontiguousarray(a, dtype=float) for a in (
            g.ring_a_anchors, g.ring_b_anchors, g.ring_a_joint_axes, g.ring_b_joint_axes)),
            np.array([g.min_length, g.max_length, g.universal_max_angle, g.spherical_max_angle,
                      g.leg_radius, g.characteristic_length, g.min_conditioning]))
        _limit_arrays[id(geometry)] = (geometry, arrays)
    return arrays


def segment_distances(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Minimum distance between segments p0->p1 and q0->q1, broadcast over leading axes (..., 3).

    Closed form of the clamped closest-point problem (as in Ericson, Real-Time Collision
    Detection, 5.1.9); degenerate (zero-length) and parallel segments are handled.
    """
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum('...k,...k->...', d1, d1)
    e = np.einsum('...k,...k->...', d2, d2)
    b = np.einsum('...k,...k->...', d1, d2)
    c = np.einsum('...k,...k->...', d1, r)
    f = np.einsum('...k,...k->...', d2, r)
    tiny = 1e-30
    a_pt = a <= tiny  # p is a point
    e_pt = e <= tiny  # q is a point
    a_safe = np.where(a_pt, 1.0, a)
    e_safe = np.where(e_pt, 1.0, e)
    denom = a * e - b * b
    parallel = denom <= 1e-12 * a * e
    # General case: closest point of the infinite lines, s clamped, then t, then s re-clamped.
    s = np.where(parallel, 0.0, np.clip((b * f - c * e) / np.where(parallel, 1.0, denom), 0.0, 1.0))
    t = (b * s + f) / e_safe
    s = np.where(t < 0.0, np.clip(-c / a_safe, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / a_safe, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # q a point: t = 0, s = projection of q0 on p; p a point: s = 0, t = projection of p0 on q.
    s = np.where(e_pt, np.clip(-c / a_safe, 0.0, 1.0), s)
    t = np.where(e_pt, 0.0, t)
    s = np.where(a_pt, 0.0, s)
    t = np.where(a_pt, np.where(e_pt, 0.0, np.clip(f / e_safe, 0.0, 1.0)), t)
    gap = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    distance = np.sqrt(np.einsum('...k,...k->...', gap, gap))
    if not np.any(parallel):
        return distance
    # (Nearly) parallel segments: s = 0 above is off by up to |d1| * 1e-6 when they are not
    # exactly parallel; the minimum is attained at an endpoint of one of them.
    ends = np.minimum(np.minimum(_point_segment_distance(p0, q0, d2, e_safe),
                                 _point_segment_distance(p1, q0, d2, e_safe)),
                      np.minimum(_point_segment_distance(q0, p0, d1, a_safe),
                                 _point_segment_distance(q1, p0, d1, a_safe)))
    return np.where(parallel, np.minimum(distance, ends), distance)


def _point_segment_distance(x: np.ndarray, q0: np.ndarray, d: np.ndarray, dd: np.ndarray) -> np.ndarray:
    """Distance from points x to segments q0 -> q0 + d (dd = d.d, 1 for a point segment)."""
    t = np.clip(np.einsum('...k,...k->...', x - q0, d) / dd, 0.0, 1.0)
    gap = x - (q0 + t[..., None] * d)
    return np.sqrt(np.einsum('...k,...k->...', gap, gap))


def inverse_condition_number(geometry: RobotGeometry, ik: InverseKinematicsResult) -> np.ndarray:
    """sigma_min / sigma_max of J with its angular columns divided by the characteristic length."""
    J = inverse_jacobian(ik)
    scale = np.array([1.0, 1.0, 1.0] + [1.0 / geometry.characteristic_length] * 3)
    Js = J * scale
    finite = np.all(np.isfinite(Js), axis=(-2, -1))
    Js = np.where(finite[..., None, None], Js, 0.0)
    sv = np.linalg.svd(Js, compute_uv=False)
    with np.errstate(divide='ignore', invalid='ignore'):
        inv = np.where(sv[..., 0] > 0.0, sv[..., -1] / sv[..., 0], 0.0)
    return np.where(finite, inv, np.nan)


@dataclass(frozen=True)
class Margins:
    """Signed margins of one pose or a batch (see the module docstring for every field).

    Also kept: the raw quantities behind them, ``lengths`` [m], ``universal_cone_angles`` and
    ``spherical_cone_angles`` [rad], ``segment_distances`` (N, 15) [m].
    """

    geometry: RobotGeometry = field(repr=False)
    lengths: np.ndarray
    universal_cone_angles: np.ndarray
    spherical_cone_angles: np.ndarray
    segment_distances: np.ndarray
    stroke: np.ndarray
    universal: np.ndarray
    spherical: np.ndarray
    interference: np.ndarray
    inverse_condition: np.ndarray
    conditioning: np.ndarray
    ok: np.ndarray
    pairs: np.ndarray = field(default_factory=lambda: PAIRS)

    @property
    def within_limits(self):
        """Same as ``ok``: bool for a single pose, (N,) bool for a batch."""
        return self.ok

    @property
    def minimum(self) -> dict[str, np.ndarray]:
        """Smallest margin of each kind (per pose for a batch)."""
        return {
            'stroke': np.min(self.stroke, axis=-1),
            'universal': np.min(self.universal, axis=-1),
            'spherical': np.min(self.spherical, axis=-1),
            'interference': np.min(self.interference, axis=-1),
            'conditioning': self.conditioning,
        }

    def broken(self) -> list[LimitViolation] | list[list[LimitViolation]]:
        """Every broken limit as :class:`LimitViolation` data, in the order stroke, universal,
        spherical, interference, conditioning; for a batch, one list per pose."""
        if np.ndim(self.ok) == 0:
            return self._pose_broken(())
        return [self._pose_broken((k,)) for k in range(len(self.ok))]

    def violations(self) -> list[str]:
        """One line per violated limit, naming the limit and the leg(s); empty when all are met.

        The words of :meth:`broken`; for a batch each line starts with ``pose k:``.
        """
        if np.ndim(self.ok) == 0:
            return [str(v) for v in self._pose_broken(())]
        out = []
        for k in np.flatnonzero(~np.asarray(self.ok)):
            out += [f'pose {k}: {v}' for v in self._pose_broken((k,))]
        return out

    @property
    def reason(self) -> str:
        """``'within limits'`` or the violations joined by ``'; '``."""
        lines = self.violations()
        return '; '.join(lines) if lines else 'within limits'

    def _pose_broken(self, k: tuple) -> list[LimitViolation]:
        g = self.geometry
        out = []
        L = self.lengths[k]
        for i in np.flatnonzero(~(self.stroke[k] >= 0.0)):
            bound = g.min_length if L[i] < g.min_length else g.max_length
            out.append(LimitViolation(LimitKind.STROKE, (int(i) + 1,), float(L[i]), float(bound)))
        for i in np.flatnonzero(~(self.universal[k] >= 0.0)):
            out.append(LimitViolation(LimitKind.UNIVERSAL, (int(i) + 1,),
                                      float(self.universal_cone_angles[k][i]),
                                      float(g.universal_max_angle)))
        for i in np.flatnonzero(~(self.spherical[k] >= 0.0)):
            out.append(LimitViolation(LimitKind.SPHERICAL, (int(i) + 1,),
                                      float(self.spherical_cone_angles[k][i]),
                                      float(g.spherical_max_angle)))
        for p in np.flatnonzero(~(self.interference[k] >= 0.0)):
            i, j = self.pairs[p]
            out.append(LimitViolation(LimitKind.INTERFERENCE, (int(i) + 1, int(j) + 1),
                                      float(self.segment_distances[k][p]), 2.0 * g.leg_radius))
        c = self.inverse_condition[k]
        if not (self.conditioning[k] >= 0.0 and c > 0.0):
            out.append(LimitViolation(LimitKind.CONDITIONING, (), float(c),
                                      float(g.min_conditioning)))
        return out


def margins(geometry: RobotGeometry, ik: InverseKinematicsResult) -> Margins:
    """Every signed margin of the pose(s) solved in ``ik`` (see the module docstring)."""
    g = geometry
    L = ik.lengths
    stroke = np.minimum(L - g.min_length, g.max_length - L)
    ua = ik.universal_cone_angles
    sa = ik.spherical_cone_angles
    universal = g.universal_max_angle - ua
    spherical = g.spherical_max_angle - sa
    a = np.broadcast_to(g.ring_a_anchors, ik.leg_vectors.shape)
    b = ik.ring_b_anchors_in_a
    i, j = PAIRS[:, 0], PAIRS[:, 1]
    dist = segment_distances(a[..., i, :], b[..., i, :], a[..., j, :], b[..., j, :])
    interference = dist - 2.0 * g.leg_radius
    inv_cond = inverse_condition_number(g, ik)
    conditioning = inv_cond - g.min_conditioning
    ok = (np.all(stroke >= 0.0, axis=-1) & np.all(universal >= 0.0, axis=-1)
          & np.all(spherical >= 0.0, axis=-1) & np.all(interference >= 0.0, axis=-1)
          & (conditioning >= 0.0) & (inv_cond > 0.0))
    if np.ndim(ok) == 0:
        ok = bool(ok)
        inv_cond = np.float64(inv_cond)
        conditioning = np.float64(conditioning)
    return Margins(geometry=g, lengths=L, universal_cone_angles=ua, spherical_cone_angles=sa,
                   segment_distances=dist, stroke=stroke, universal=universal,
                   spherical=spherical, interference=interference,
                   inverse_condition=inv_cond, conditioning=conditioning, ok=ok)


class PoseMargins(NamedTuple):
    """Every margin of one pose as plain arrays (see :class:`Margins` for their meaning), the
    light record of the real-time guards: ``lengths``, ``stroke``, ``universal``,
    ``spherical`` (6,), ``interference`` (15,), ``inverse_condition`` and ``conditioning``
    (its margin over the robot's min_conditioning)."""

    lengths: np.ndarray
    stroke: np.ndarray
    universal: np.ndarray
    spherical: np.ndarray
    interference: np.ndarray
    inverse_condition: float
    conditioning: float

    @property
    def ok(self) -> bool:
        """Whether the pose is within every limit (as :attr:`Margins.ok`; NaN is a violation)."""
        return bool(np.all(self.stroke >= 0.0) and np.all(self.universal >= 0.0)
                    and np.all(self.spherical >= 0.0) and np.all(self.interference >= 0.0)
                    and self.conditioning >= 0.0 and self.inverse_condition > 0.0)

    @property
    def minimum(self) -> dict[str, float]:
        """Smallest margin of each kind, as :attr:`Margins.minimum`."""
        return {'stroke': float(np.min(self.stroke)), 'universal': float(np.min(self.universal)),
                'spherical': float(np.min(self.spherical)),
                'interference': float(np.min(self.interference)),
                'conditioning': float(self.conditioning)}


def pose_margins(geometry: RobotGeometry, position, quaternion_xyzw, *,
                 backend: str = 'auto') -> PoseMargins:
    """Every margin of one pose a_T_b (unit quaternion): a numba kernel when available (a few
    microseconds, no NumPy call per leg), else :func:`margins`; the same numbers."""
    p = np.ascontiguousarray(position, dtype=float)
    q = np.ascontiguousarray(quaternion_xyzw, dtype=float)
    if use_numba(backend):
        from rrps_kinematics.compiled_limits import pose_margin_arrays
        buffer = np.empty(39)  # one allocation; the record's arrays are views of it
        lengths, stroke, universal, spherical = (buffer[6 * k:6 * k + 6] for k in range(4))
        interference = buffer[24:]
        inv_cond = pose_margin_arrays(limit_arrays(geometry), p, q, lengths, stroke, universal,
                                      spherical, interference)
        return PoseMargins(lengths, stroke, universal, spherical, interference, float(inv_cond),
                           float(inv_cond) - geometry.min_conditioning)
    m = margins(geometry, inverse_kinematics(geometry, p, q))
    return PoseMargins(np.asarray(m.lengths), np.asarray(m.stroke), np.asarray(m.universal),
                       np.asarray(m.spherical), np.asarray(m.interference),
                       float(m.inverse_condition), float(m.conditioning))


def check_pose(geometry: RobotGeometry, position, quaternion_xyzw) -> tuple[bool, str, Margins]:
    """(ok, reason, margins) of one pose a_T_b; reason is ``'within limits'`` when ok.

    Malformed input (shapes, NaN, zero quaternion) raises ValueError, like inverse_kinematics.
    """
    m = margins(geometry, inverse_kinematics(geometry, position, quaternion_xyzw))
    if np.ndim(m.ok) != 0:
        raise ValueError('check_pose takes a single pose; use margins() for batches')
    return m.ok, m.reason, m
