"""Passive, bounded leg forces for a master robot's drives: the operator feels the slave's limits
and the master never puts energy into the operator's hand.

Per leg, ``F = clip(F_w - damping * v, -limit, limit)`` with ``F_w`` the clipped wanted force
limited by a time-domain passivity observer (Hannaford and Ryu, IEEE T-RA 18(1), 2002): it gives
back at most the energy the hand put into the leg, ``E += -F_prev * (x - x_prev)``. Pure Python.
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
        rendered = np.clip(np.asarray(wanted, dtype=float), -self.limit, self.limit)
        budget = np.maximum(self.stored, 0.0)
        over = rendered * v * dt > budget                             # it would give more than it got
        rendered = np.where(over, budget / np.where(over, v * dt, 1.0), rendered)
        rendered = np.where(self.stored < 0.0, 0.0, rendered)
        self.forces = np.clip(rendered - self.damping * v, -self.limit, self.limit)
        return self.forces.copy()
