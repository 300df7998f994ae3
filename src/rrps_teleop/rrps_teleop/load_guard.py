"""The teleop load guards: slow down near, and halt at, the actuator force limit and a holding
margin of zero, as the stroke and conditioning guards do (:mod:`rrps_teleop.guards`).

The margins come from the statics at rest (eq. 19, :func:`rrps_loads.compiled_statics.pose_statics`)
on the supporting ring: force 1 - max_i |f_i| / max_force, holding 1 - the gripper's utilisation
(:func:`rrps_loads.loads.holding_margin`; +inf without a capacity).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_interfaces.teleop import TeleopCode
from rrps_kinematics.backend import kernels_of, use_numba
from rrps_kinematics.limits import limit_arrays
from rrps_loads import compiled_statics
from rrps_loads.compiled_statics import statics_arrays
from rrps_loads.support import Support
from rrps_teleop import compiled_guards
from rrps_teleop.command_layout import COMMAND_SIZE, STEP_ACCEPTED, STEP_FK_FAILED
from rrps_teleop.guards import GuardedCommand
from rrps_teleop.teleop_config import TeleopConfig

__all__ = ['LoadMargins', 'LoadGuard']


class LoadMargins(NamedTuple):
    """The load margins of one command: ``force`` and ``holding`` (fractions, see the module
    docstring), the ``forces`` (6,) [N] and the leg (0-5) of the largest |f_i|."""

    force: float
    holding: float
    forces: np.ndarray
    leg: int


def _worse(new: float, old: float) -> bool:
    """A margin that is negative (or NaN) and not better than before."""
    return not (new >= 0.0) and not (new >= old)


class LoadGuard:
    """The load limits of ``slave`` (its payload and tool wrench) on ``support``.

    ``backend``: 'auto' (the kernels compiled with numba), 'numba' or 'numpy' (interpreted).
    """

    def __init__(self, slave: RobotGeometry, support: Support | None = None, *, backend: str = 'auto'):
        self.slave = slave
        self.support = Support.of() if support is None else support
        compiled = use_numba(backend)
        self._lists = not compiled
        self._arrays = self._statics_arrays(self.support)
        self._statics = kernels_of(compiled_statics, backend)
        #: the guards' kernels (:mod:`.compiled_guards`) scale a step
        self._kernels = kernels_of(compiled_guards, backend)
        self._limits = limit_arrays(slave, lists=not compiled)
        self._forces, self._wrench = np.empty(6), np.empty(6)
        self._cached: tuple[GuardedCommand, LoadMargins] | None = None

    def set_support(self, support: Support) -> None:
        """Guard on ``support`` from now on (the ring that grips, its attitude in the world)."""
        self.support = support
        self._arrays = self._statics_arrays(support)
        self._cached = None

    def _statics_arrays(self, support: Support):
        """The statics kernels' arrays of the slave on ``support`` (lists when interpreted)."""
        arrays = statics_arrays(self.slave, support)
        return type(arrays)(*(a.tolist() for a in arrays)) if self._lists else arrays

    def margins_at(self, position, quaternion_xyzw) -> LoadMargins:
        """The load margins with ring_b at (position, quaternion) in ring_a (NaN forces and
        margins at a singular pose)."""
        holding = self._statics.pose_statics(self._arrays, np.asarray(position, dtype=float),
                                             np.asarray(quaternion_xyzw, dtype=float), self._forces, self._wrench)
        forces = self._forces.copy()
        if not np.all(np.isfinite(forces)):
            return LoadMargins(math.nan, math.nan, forces, 0)
        if self.support.ring not in self.slave.holding:
            holding = math.inf
        leg = int(np.argmax(np.abs(forces)))
        return LoadMargins(1.0 - abs(float(forces[leg])) / self.slave.max_force, holding, forces, leg)

    def warm_up(self, command: GuardedCommand, halt: float) -> None:
        """Load (or compile) the kernels now, for the argument types of a real step."""
        self.margins_at(command.position, command.quaternion)
        self._scaled(command, command, 0.5, False, halt)

    def margins(self, command: GuardedCommand) -> LoadMargins:
        """:meth:`margins_at` the command's pose (the last command's are kept)."""
        if self._cached is None or self._cached[0] is not command:
            self._cached = (command, self.margins_at(command.position, command.quaternion))
        return self._cached[1]

    def step(self, prev: GuardedCommand, cand: GuardedCommand, code: TeleopCode, config: TeleopConfig,
             halt: float, *, joint: bool) -> tuple[GuardedCommand | None, TeleopCode, str]:
        """Guard the kinematically accepted step ``prev`` -> ``cand`` (its status ``code``):
        (the command, or None to hold, its TeleopCode, the detail). ``joint``: a joint-mode step
        (scaled along the leg lengths, else along the pose); ``halt``: the conditioning guard's."""
        m0, m1 = self.margins(prev), self.margins(cand)
        factor, slowed = 1.0, code
        for before, after, band, slow, stop in (
                (m0.force, m1.force, config.force_slowdown, TeleopCode.DECELERATE_FOR_FORCE, TeleopCode.HALT_FOR_FORCE),
                (m0.holding, m1.holding, config.holding_slowdown, TeleopCode.DECELERATE_FOR_HOLDING,
                 TeleopCode.HALT_FOR_HOLDING)):
            if after < before and before < band:
                f = min(max(before / band, 0.0), 1.0)
                if f < factor:
                    factor, slowed = f, (slow if f > 0.0 else stop)
        if factor < 1.0:
            outcome, cand = self._scaled(prev, cand, factor, joint, halt)
            if outcome == STEP_FK_FAILED:
                return None, TeleopCode.INVALID, 'FK of the load-guarded leg lengths did not converge: holding'
            if outcome != STEP_ACCEPTED:
                return None, slowed, 'a load-guarded step would break a kinematic margin: holding'
            m1 = self.margins(cand)
        if _worse(m1.force, m0.force):
            return None, TeleopCode.HALT_FOR_FORCE, (
                f'actuator force: leg_{m1.leg + 1} {m1.forces[m1.leg]:.1f} N beyond max_force '
                f'{self.slave.max_force:g} N (margin {m1.force:.4g}): holding')
        if _worse(m1.holding, m0.holding):
            return None, TeleopCode.HALT_FOR_HOLDING, (
                f"holding margin of {self.support.ring}'s gripper {m1.holding:.4g} would be negative: holding")
        return cand, slowed, ''

    def _scaled(self, prev: GuardedCommand, cand: GuardedCommand, factor: float, joint: bool,
                halt: float) -> tuple[int, GuardedCommand]:
        """(STEP_*, the command a ``factor`` of the way from ``prev`` to ``cand``): along the leg
        lengths (an FK warm-started at prev) or along the pose (straight line, constant-axis
        rotation); refused when it breaks or worsens a kinematic margin."""
        g = self.slave
        out = np.empty(COMMAND_SIZE)
        outcome = self._kernels.scaled_step(self._limits, 1.0 / g.characteristic_length, prev.buffer,
                                            cand.buffer, factor, joint, halt, out)
        return outcome, GuardedCommand(out, g.min_conditioning)
