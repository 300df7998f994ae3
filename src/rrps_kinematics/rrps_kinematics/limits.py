"""Limits of an RRPS pose as signed margins (positive = inside the limit, SI units).

``stroke`` [m], the ``universal`` and ``spherical`` joint cones [rad], leg ``interference``
(:data:`PAIRS`, Fig. 8c) [m] and ``conditioning``, of one pose or a batch, by one kernel
(:mod:`.compiled_limits`); every margin is defined in docs/robot-model.md, 'Pose limits'.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from itertools import combinations
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.backend import interpreted, use_numba
from rrps_kinematics.inverse import InverseKinematicsResult, inverse_kinematics

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


_limit_arrays: dict[tuple[int, bool], tuple[RobotGeometry, LimitArrays]] = {}


def limit_arrays(geometry: RobotGeometry, *, lists: bool = False) -> LimitArrays:
    """The :class:`LimitArrays` of ``geometry`` (built once per geometry object); with ``lists``
    as Python lists (what the interpreted kernels index quickest)."""
    entry = _limit_arrays.get((id(geometry), lists))
    arrays = entry[1] if entry is not None and entry[0] is geometry else None
    if arrays is None:
        g = geometry
        arrays = LimitArrays(*(np.ascontiguousarray(a, dtype=float) for a in (
            g.ring_a_anchors, g.ring_b_anchors, g.ring_a_joint_axes, g.ring_b_joint_axes)),
            np.array([g.min_length, g.max_length, g.universal_max_angle, g.spherical_max_angle,
                      g.leg_radius, g.characteristic_length, g.min_conditioning]))
        if lists:
            arrays = LimitArrays(*(a.tolist() for a in arrays))
        _limit_arrays[(id(geometry), lists)] = (geometry, arrays)
    return arrays


def _kernels(backend: str):
    """(the limits' kernels, their robot arrays as lists or not): compiled, or interpreted."""
    from rrps_kinematics import compiled_limits
    return compiled_limits, not use_numba(backend)


def segment_distances(p0, p1, q0, q1, *, backend: str = 'auto') -> np.ndarray:
    """Minimum distance between segments p0->p1 and q0->q1, broadcast over leading axes (..., 3)
    (the kernel :func:`rrps_kinematics.compiled_limits.segment_distance`)."""
    p0, p1, q0, q1 = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (p0, p1, q0, q1)))
    shape = p0.shape[:-1]
    kernels, lists = _kernels(backend)
    flat = [np.ascontiguousarray(x.reshape(-1, 3)) for x in (p0, p1, q0, q1)]
    if lists:
        out = [0.0] * len(flat[0])
        interpreted(kernels.segment_distances_batch)(*(x.tolist() for x in flat), out)
        return np.array(out, dtype=float).reshape(shape)
    out = np.empty(len(flat[0]))
    kernels.segment_distances_batch(*flat, out)
    return out.reshape(shape)


def inverse_condition_number(geometry: RobotGeometry, ik: InverseKinematicsResult) -> np.ndarray:
    """sigma_min / sigma_max of J with its angular columns divided by the characteristic length."""
    return margins(geometry, ik).inverse_condition


@dataclass(frozen=True)
class Margins:
    """Signed margins of one pose or a batch (every field: docs/robot-model.md, 'Pose limits').

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


def margins(geometry: RobotGeometry, ik: InverseKinematicsResult, *, backend: str = 'auto') -> Margins:
    """Every signed margin of the pose(s) solved in ``ik`` (docs/robot-model.md), from the
    kernel :func:`rrps_kinematics.compiled_limits.margins_batch`."""
    g = geometry
    batch = np.shape(ik.position)[:-1]
    P = np.ascontiguousarray(np.reshape(ik.position, (-1, 3)), dtype=float)
    R = np.ascontiguousarray(np.reshape(ik.rotation, (-1, 9)), dtype=float)
    n = len(P)
    widths = (6, 6, 6, len(PAIRS), 6, 6, 6, len(PAIRS))
    kernels, lists = _kernels(backend)
    if lists:
        outs = [[[0.0] * w for _ in range(n)] for w in widths]
        inv = [0.0] * n
        interpreted(kernels.margins_batch)(limit_arrays(g, lists=True), P.tolist(), R.tolist(), *outs, inv)
        outs = [np.array(o, dtype=float).reshape(n, w) for o, w in zip(outs, widths)]
        inv = np.array(inv, dtype=float)
    else:
        outs = [np.empty((n, w)) for w in widths]
        inv = np.empty(n)
        kernels.margins_batch(limit_arrays(g), P, R, *outs, inv)
    L, ua, sa, dist, stroke, universal, spherical, interference = (o.reshape(batch + o.shape[1:]) for o in outs)
    inv_cond = inv.reshape(batch)
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
    """Every margin of one pose a_T_b (unit quaternion): the kernel of :func:`margins` for one
    pose, without NumPy's per-call overhead (a few microseconds compiled)."""
    p = np.ascontiguousarray(position, dtype=float)
    q = np.ascontiguousarray(quaternion_xyzw, dtype=float)
    kernels, lists = _kernels(backend)
    if lists:
        out = [[0.0] * 6 for _ in range(4)] + [[0.0] * len(PAIRS)]
        inv_cond = interpreted(kernels.pose_margin_arrays)(limit_arrays(geometry, lists=True), p.tolist(),
                                                           q.tolist(), *out)
        lengths, stroke, universal, spherical, interference = (np.array(o, dtype=float) for o in out)
    else:
        buffer = np.empty(39)  # one allocation; the record's arrays are views of it
        lengths, stroke, universal, spherical = (buffer[6 * k:6 * k + 6] for k in range(4))
        interference = buffer[24:]
        inv_cond = kernels.pose_margin_arrays(limit_arrays(geometry), p, q, lengths, stroke, universal,
                                              spherical, interference)
    return PoseMargins(lengths, stroke, universal, spherical, interference, float(inv_cond),
                       float(inv_cond) - geometry.min_conditioning)


def check_pose(geometry: RobotGeometry, position, quaternion_xyzw) -> tuple[bool, str, Margins]:
    """(ok, reason, margins) of one pose a_T_b; reason is ``'within limits'`` when ok.

    Malformed input (shapes, NaN, zero quaternion) raises ValueError, like inverse_kinematics.
    """
    m = margins(geometry, inverse_kinematics(geometry, position, quaternion_xyzw))
    if np.ndim(m.ok) != 0:
        raise ValueError('check_pose takes a single pose; use margins() for batches')
    return m.ok, m.reason, m
