"""Position-controlled actuators (lag + limits): the kinematic legs and rings of the simulated
hardware and the simulated CANopen drives. Pure NumPy, no ROS import. Positions [m] or [rad],
speeds per second, ``dt`` [s]. Apart from :mod:`rrps_sim.actuators` (statics and dynamics), so that
a drive simulator loads NumPy only.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['KinematicActuators']


def _vector(value, n: int, name: str) -> np.ndarray:
    v = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    if np.any(np.isnan(v)):
        raise ValueError(f'{name} contains NaN')
    return v


class KinematicActuators:
    """Position-controlled actuators: per axis, a first-order lag toward the reference (``tau = 0``:
    none), then speed and stroke limits; arrays (n,) or scalars, ``max_speed`` may be inf."""

    def __init__(self, min_position, max_position, max_speed, time_constant: float, initial):
        x0 = np.asarray(initial, dtype=float)
        if x0.ndim != 1 or not np.all(np.isfinite(x0)):
            raise ValueError(f'initial positions must be a finite vector, got {initial!r}')
        n = x0.size
        self.min_position = _vector(min_position, n, 'min_position')
        self.max_position = _vector(max_position, n, 'max_position')
        self.max_speed = _vector(max_speed, n, 'max_speed')
        if not np.all(self.min_position < self.max_position):
            raise ValueError('min_position must be < max_position')
        if not np.all(self.max_speed > 0.0):
            raise ValueError('max_speed must be > 0')
        if not (math.isfinite(time_constant) and time_constant >= 0.0):
            raise ValueError(f'time_constant must be finite and >= 0, got {time_constant}')
        if np.any(x0 < self.min_position) or np.any(x0 > self.max_position):
            raise ValueError(f'initial positions {x0} outside [{self.min_position}, {self.max_position}]')
        self.time_constant = float(time_constant)
        self.positions = x0.copy()
        self.velocities = np.zeros(n)
        self.stuck = np.zeros(n, dtype=bool)

    @property
    def efforts(self) -> np.ndarray:
        """Not modelled by the kinematic actuators: empty."""
        return np.zeros(0)

    def step(self, reference, dt: float) -> None:
        """Advance by ``dt`` >= 0 s toward ``reference`` (n,); stuck axes keep their position."""
        r = np.asarray(reference, dtype=float)
        if r.shape != self.positions.shape or not np.all(np.isfinite(r)):
            raise ValueError(f'reference must be {self.positions.size} finite numbers, got {r!r}')
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f'dt must be finite and >= 0, got {dt}')
        x = self.positions
        r = np.clip(r, self.min_position, self.max_position)
        r = np.where(self.stuck, x, r)
        lagged = r if self.time_constant == 0.0 else r + (x - r) * math.exp(-dt / self.time_constant)
        reach = np.full_like(x, np.inf)
        finite = np.isfinite(self.max_speed)
        reach[finite] = self.max_speed[finite] * dt
        delta = np.clip(lagged - x, -reach, reach)
        self.positions = x + delta
        self.velocities = delta / dt if dt > 0.0 else np.zeros_like(delta)
