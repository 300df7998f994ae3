"""A timing law s(t) of a path: TOPP-RA's bang-bang profile (:class:`TimingLaw`) made jerk-limited.

A moving average over a window W (Biagiotti and Melchiorri, 2008, ch. 4) keeps speed and
acceleration within the profile's bounds, bounds the jerk by the largest change of s̈ over W / W,
and lasts W longer; :func:`jerk_window` picks the shortest W. A time scale ``scale`` >= 1 divides
speed, acceleration and jerk by scale, scale² and scale³. Why not Ruckig: benchmarks/jerk_limiting.py.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['TimingLaw', 'SmoothedLaw', 'jerk_window']


class TimingLaw:
    """The piecewise-quadratic s(t) through gridpoints ``s`` (N+1,) at path speeds ``sd`` (N+1,),
    from rest to rest (``sd[0] = sd[-1] = 0``); ValueError when an interval cannot be crossed
    (zero speed at both of its ends)."""

    def __init__(self, s, sd):
        s, sd = np.asarray(s, dtype=float), np.maximum(np.asarray(sd, dtype=float), 0.0)
        ds = np.diff(s)
        mean = sd[:-1] + sd[1:]
        if np.any(mean <= 0.0):
            i = int(np.flatnonzero(mean <= 0.0)[0])
            raise ValueError(f'the path speed is zero on interval {i} of {len(ds)}: the motion stops there')
        self.s, self.sd = s, sd
        self.u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * ds)
        dt = 2.0 * ds / mean
        self.t = np.concatenate([[0.0], np.cumsum(dt)])
        # S(t) at the gridpoints: the integral of s over each interval
        pieces = s[:-1] * dt + 0.5 * sd[:-1] * dt ** 2 + self.u * dt ** 3 / 6.0
        self.S = np.concatenate([[0.0], np.cumsum(pieces)])

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def _at(self, t):
        t = np.asarray(t, dtype=float)
        i = np.clip(np.searchsorted(self.t, t, side='right') - 1, 0, len(self.u) - 1)
        tau = np.clip(t, 0.0, self.duration) - self.t[i]
        return t, i, tau

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(S, s, ṡ, s̈) at times ``t``: rest at 0 before the start, at the end after it."""
        t, i, tau = self._at(t)
        u = self.u[i]
        s = self.s[i] + self.sd[i] * tau + 0.5 * u * tau ** 2
        S = self.S[i] + self.s[i] * tau + 0.5 * self.sd[i] * tau ** 2 + u * tau ** 3 / 6.0
        after = t > self.duration
        S = np.where(t < 0.0, 0.0, np.where(after, self.S[-1] + self.s[-1] * (t - self.duration), S))
        moving = (t >= 0.0) & ~after
        return S, np.where(t < 0.0, 0.0, s), np.where(moving, self.sd[i] + u * tau, 0.0), np.where(moving, u, 0.0)


class SmoothedLaw:
    """``law`` averaged over ``window`` [s] and slowed by ``scale`` (module docstring)."""

    def __init__(self, law: TimingLaw, window: float, scale: float = 1.0):
        if not (window >= 0.0 and scale >= 1.0):
            raise ValueError(f'window must be >= 0 and scale >= 1, got {window}, {scale}')
        self.law, self.window, self.scale = law, float(window), float(scale)

    @property
    def duration(self) -> float:
        """How long the smoothed law lasts [s]."""
        return (self.law.duration + self.window) * self.scale

    @property
    def length(self) -> float:
        return float(self.law.s[-1])

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, ṡ, s̈) at times ``t`` [s] (arrays)."""
        tau = np.asarray(t, dtype=float) / self.scale
        W, k = self.window, self.scale
        S1, s1, v1, a1 = self.law.evaluate(tau)
        if W == 0.0:
            return s1, v1 / k, a1 / k ** 2
        S0, s0, v0, a0 = self.law.evaluate(tau - W)
        return (S1 - S0) / W, (s1 - s0) / (W * k), (v1 - v0) / (W * k ** 2)

    def jerk(self, t) -> np.ndarray:
        """s⃛ at times ``t`` (piecewise constant; 0 without a window)."""
        tau = np.asarray(t, dtype=float) / self.scale
        if self.window == 0.0:
            return np.zeros_like(tau)
        return (self.law.evaluate(tau)[3] - self.law.evaluate(tau - self.window)[3]) / (self.window * self.scale ** 3)


def _largest_change(law: TimingLaw, window: float) -> float:
    """max over t of |u(t) - u(t - window)| (checked where either side switches)."""
    t = np.concatenate([law.t, law.t + window])
    t = np.concatenate([t - 1e-9, t + 1e-9])
    return float(np.max(np.abs(law.evaluate(t)[3] - law.evaluate(t - window)[3])))


def jerk_window(law: TimingLaw, jerk: float) -> float:
    """The shortest window W [s] (within 1 %) whose moving average bounds the path jerk by
    ``jerk`` [1/s³]: max |u(t) - u(t - W)| <= W jerk."""
    if not (jerk > 0.0):
        raise ValueError(f'jerk must be > 0, got {jerk!r}')
    spread = max(float(np.max(law.u)), 0.0) - min(float(np.min(law.u)), 0.0)
    if spread == 0.0 or math.isinf(jerk):
        return 0.0
    jumps = np.abs(np.diff(np.concatenate([[0.0], law.u, [0.0]])))
    window = float(np.max(jumps)) / jerk
    for _ in range(50):
        needed = _largest_change(law, window) / jerk
        if needed <= window * 1.0001:
            return window
        window = min(max(needed, 1.01 * window), spread / jerk)
    return spread / jerk
