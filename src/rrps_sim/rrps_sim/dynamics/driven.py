"""The legs driven as the driver's dynamic mode drives them, compiled: many steps of the DAE with
each leg's force from the state between steps (:class:`rrps_sim.actuators.DynamicActuators`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import rotation_into
from rrps_sim.dynamics.constraints import angular_velocity
from rrps_sim.dynamics.integrators import step
from rrps_sim.dynamics.observation import leg_length_rate

__all__ = ['DriveLoop', 'driven_run']


class DriveLoop(NamedTuple):
    """The drives of the six legs: PD gains ``kp`` [N/m], ``kd`` [N s/m], the reference's lag
    ``time_constant`` [s] (0: none), ``max_speed`` (6,) [m/s] (inf: none), the stroke
    ``min_length``, ``max_length`` (6,) [m] and the force saturation ``max_force`` [N] (inf:
    none)."""

    kp: float
    kd: float
    time_constant: float
    max_speed: np.ndarray
    min_length: np.ndarray
    max_length: np.ndarray
    max_force: float


@jit
def driven_run(q, v, work, commands, period, t0, steps, dt, drive, reference, feedforward, forces,
               peak, method, alpha, beta, correction_tolerance, newton_tolerance, max_iterations,
               params, buffer):
    """``steps`` steps of ``dt`` [s] from ``t0`` [s] towards ``commands`` (n, 6) [m], one per
    ``period`` [s] (the last held), in place; ``reference``, ``forces`` and ``peak`` (the largest
    |demand| per leg [N]) are updated in place. Returns (status, work, steps done): status 0, or
    the failing step's code (the state is then that before it)."""
    Ab = np.empty((3, 3))
    last = commands.shape[0] - 1
    decay = math.exp(-dt / drive.time_constant) if drive.time_constant > 0.0 else 0.0
    for i in range(steps):
        c = min(int((t0 + i * dt) / period + 1e-9), last)
        rotation_into(q, 3, Ab)
        wb = angular_velocity(Ab, v, 0)
        for k in range(6):
            target = min(max(commands[c, k], drive.min_length[k]), drive.max_length[k])
            x = reference[k]
            reach = drive.max_speed[k] * dt
            delta = min(max(target + (x - target) * decay - x, -reach), reach)
            reference[k] = x + delta
            reference[6 + k] = delta / dt
            length, rate = leg_length_rate(q, v, k, params.joints, Ab, wb)
            f = (feedforward[k] + drive.kp * (reference[k] - length)
                 + drive.kd * (reference[6 + k] - rate))
            peak[k] = max(peak[k], abs(f))
            forces[k] = min(max(f, -drive.max_force), drive.max_force)
        status, work, _, _ = step(q, v, work, forces, dt, method, alpha, beta, correction_tolerance,
                                  newton_tolerance, max_iterations, params, buffer)
        if status != 0:
            return status, work, i
    return 0, work, steps
