"""The limits of a motion's timing along its path, as TOPP-RA's second-order constraints in
u = s̈, x = ṡ² at each gridpoint: leg speed and a path-speed cap (bounds on x), leg acceleration
|L' u + L'' x| <= a_max, and forces and the holding wrench, exactly affine in (u, x) by eq. 19
(f = C + A u + B x, :mod:`rrps_loads.path_loads`) against ``max_force`` and
:func:`rrps_loads.holding_polytope.holding_rows`. :class:`GridLimits`: rows ``a u + b x + c <= g``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rrps_climbing.path_curve import PathCurve
from rrps_description.geometry import RobotGeometry
from rrps_description.names import LEG_NAMES
from rrps_loads.holding_polytope import holding_rows
from rrps_loads.path_loads import loads_at

__all__ = ['Held', 'LoadCoefficients', 'GridLimits', 'grid_limits']


@dataclass(frozen=True)
class Held:
    """Who holds while a motion runs: the gripping ``ring``, its attitude ``world_q`` (x, y, z,
    w) in the world and the world's ``gravity`` (3,) [m/s²]."""

    ring: str
    world_q: tuple
    gravity: tuple


class LoadCoefficients(NamedTuple):
    """Actuator forces and the holding ring's wrench at N+1 gridpoints, each (N+1, 6):
    ``f = C + A u + B x`` and ``w = Cw + Aw u + Bw x``."""

    C: np.ndarray
    A: np.ndarray
    B: np.ndarray
    Cw: np.ndarray
    Aw: np.ndarray
    Bw: np.ndarray

    def at(self, s_grid: np.ndarray, s, u, x) -> tuple[np.ndarray, np.ndarray]:
        """(forces (K, 6), wrenches (K, 6)) of timed states (path position ``s``, u, x) (K,), the
        coefficients interpolated linearly between the gridpoints."""
        def lerp(y):
            return np.column_stack([np.interp(s, s_grid, y[:, j]) for j in range(y.shape[1])])
        u, x = np.asarray(u)[:, None], np.asarray(x)[:, None]
        return (lerp(self.C) + lerp(self.A) * u + lerp(self.B) * x,
                lerp(self.Cw) + lerp(self.Aw) * u + lerp(self.Bw) * x)


@dataclass(frozen=True)
class GridLimits:
    """The constraints at the gridpoints ``s`` (N+1,): ``a u + b x + c <= g`` (a, b, c (N+1, m),
    g (m,)), ``0 <= x <= x_max`` (N+1,), what each row bounds (``rows``: (limit, who)), the
    legs' L' and L'' (N+1, 6), and the load coefficients (None without a held ring)."""

    s: np.ndarray
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    g: np.ndarray
    x_max: np.ndarray
    rows: tuple
    L1: np.ndarray
    L2: np.ndarray
    loads: LoadCoefficients | None


def _load_coefficients(geometry: RobotGeometry, curve: PathCurve, s: np.ndarray, held: Held) -> LoadCoefficients:
    p, q, T1, T2 = curve.twists(s)
    n = len(s)
    zero = np.zeros_like(T1)
    loads = loads_at(geometry, np.tile(p, (3, 1)), np.tile(q, (3, 1)), np.concatenate([zero, zero, T1]),
                     np.concatenate([zero, T1, T2]), support=held.ring, world_q_support=held.world_q,
                     gravity=held.gravity)
    f, w = loads.actuator_forces, loads.support_wrench
    return LoadCoefficients(f[:n], f[n:2 * n] - f[:n], f[2 * n:] - f[:n], w[:n], w[n:2 * n] - w[:n], w[2 * n:] - w[:n])


def grid_limits(geometry: RobotGeometry, curve: PathCurve, s: np.ndarray, *, speed: float, acceleration: float,
                speed_cap: float | None = None, held: Held | None = None) -> GridLimits:
    """The :class:`GridLimits` of ``curve`` at gridpoints ``s``: the legs' ``speed`` [m/s] and
    ``acceleration`` [m/s²], the path speed ``speed_cap`` [m/s] (None: none) and, with ``held``,
    the actuators' force limit and the holding ring's capacity (module docstring)."""
    _, L1, L2 = curve.leg_rates(geometry, s)
    x_max = np.min((speed / np.maximum(np.abs(L1), 1e-12)) ** 2, axis=1)
    if speed_cap is not None:
        x_max = np.minimum(x_max, speed_cap ** 2)
    zero = np.zeros_like(L1)
    a, b, c, g = [L1, -L1], [L2, -L2], [zero, zero], [np.full(12, acceleration)]
    rows = [('acceleration', leg) for leg in LEG_NAMES] * 2
    coefficients = None
    if held is not None:
        coefficients = k = _load_coefficients(geometry, curve, s, held)
        if math.isfinite(geometry.max_force):
            a += [k.A, -k.A]
            b += [k.B, -k.B]
            c += [k.C, -k.C]
            g.append(np.full(12, float(geometry.max_force)))
            rows += [('actuator_force', leg) for leg in LEG_NAMES] * 2
        capacity = geometry.holding.get(held.ring)
        if capacity is not None:
            G, h = holding_rows(capacity)
            static = k.Cw @ G.T
            a.append(k.Aw @ G.T)
            b.append(k.Bw @ G.T)
            c.append(static - np.maximum(static - h, 0.0))   # a row the rest pose lies beyond moves out to it
            g.append(h)
            rows += [('holding', held.ring)] * len(h)
    return GridLimits(s=s, a=np.concatenate(a, axis=1), b=np.concatenate(b, axis=1), c=np.concatenate(c, axis=1),
                      g=np.concatenate(g), x_max=x_max, rows=tuple(rows), L1=L1, L2=L2, loads=coefficients)
