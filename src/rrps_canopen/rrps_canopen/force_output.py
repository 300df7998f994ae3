"""Passive, bounded leg forces for a master robot's drives: the operator feels the slave's limits
and the master never puts energy into the operator's hand.

Per leg (each a port of force ``F`` and speed ``v``): ``F = clip(F_wanted - damping * v,
-limit, limit)``, then a time-domain passivity controller: an observer sums the energy that
went *into* the leg from the hand, ``E += -F_prev * (x - x_prev)``, and the next force may give
back at most that energy over the next period (``F * v * dt <= E``), so that the work the drive
does on the hand, ``-E``, never exceeds zero beyond one period's rounding (Hannaford and Ryu,
"Time-domain passivity control of haptic interfaces", IEEE T-RA 18(1), 2002). Pure Python.
"""

from __future__ import annotations

import numpy as np

__all__ = ['PassiveForceOutput']


class PassiveForceOutput:
    """Leg forces [N] from wanted ones (see the module docstring); ``limit`` [N], ``damping`` [N s/m]."""

    def __init__(self, n: int, *, limit: float, damping: float):
        if not limit > 0.0 or damping < 0.0:
            raise ValueError(f'limit must be > 0 and damping >= 0, got {limit}, {damping}')
        self.limit, self.damping = float(limit), float(damping)
        self.stored = np.zeros(n)        # [J] energy the hand put into each leg, not yet given back
        self.forces = np.zeros(n)        # [N] the forces of the last period
        self._x: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the energy and the forces (the output was off)."""
        self.stored[:] = 0.0
        self.forces[:] = 0.0
        self._x = None

    def __call__(self, wanted: np.ndarray, positions: np.ndarray, velocities: np.ndarray, dt: float) -> np.ndarray:
        """This period's forces for the ``wanted`` ones, with the legs at ``positions`` [m] moving
        at ``velocities`` [m/s]; ``dt`` [s] the period."""
        x = np.asarray(positions, dtype=float)
        if self._x is not None:
            self.stored = self.stored - self.forces * (x - self._x)   # the work the hand did on the drive
        self._x = x.copy()
        v = np.asarray(velocities, dtype=float)
        f = np.clip(np.asarray(wanted, dtype=float) - self.damping * v, -self.limit, self.limit)
        giving = f * v * dt                                           # > 0: the drive would push the hand
        budget = np.maximum(self.stored, 0.0)
        over = (giving > budget) & (np.abs(v) * dt > 0.0)
        f = np.where(over, budget / np.where(over, v * dt, 1.0), f)
        self.forces = np.clip(f, -self.limit, self.limit)
        return self.forces.copy()
