"""One guarded teleop step of a slave robot (§3.1): :class:`GuardedStep` binds the kernels of
:mod:`rrps_teleop.compiled_guards` and the load guards (:mod:`rrps_teleop.load_guard`) to one
robot's limits and says with a :class:`TeleopCode` what limited the step.
"""

from __future__ import annotations

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_interfaces.teleop import TeleopCode
from rrps_kinematics.backend import kernels_of, use_numba
from rrps_kinematics.limits import limit_arrays, pose_margins
from rrps_teleop import compiled_guards
from rrps_teleop.command_layout import (
    CHECK_CONDITIONING,
    COMMAND_SIZE,
    STEP_FK_FAILED,
    STEP_REFUSED,
    STEP_UNCHANGED,
)
from rrps_teleop.guards import CHECK_STARTS, LEG_SPEED_ITERATIONS, GuardedCommand
from rrps_teleop.load_guard import LoadGuard
from rrps_teleop.teleop_config import TeleopConfig

__all__ = ['GuardedStep']


class GuardedStep:
    """The guarded steps of one slave robot; each returns (command, code, detail): the accepted
    candidate, or the previous command when the step is refused or changes nothing.

    ``backend``: 'auto' (the kernels compiled when numba is available), 'numba' or 'numpy'.
    """

    def __init__(self, slave: RobotGeometry, loads: LoadGuard, backend: str = 'auto'):
        self.slave = slave
        self.loads = loads
        #: whether the kernels are compiled by numba (else interpreted)
        self.compiled = use_numba(backend)
        #: the guards' kernels (:mod:`.compiled_guards`), compiled or interpreted
        self.kernels = kernels_of(compiled_guards, backend)
        self._limit_arrays = limit_arrays(slave, lists=not self.compiled)

    def halt(self, config: TeleopConfig) -> float:
        """Inverse condition number where motion towards a singularity halts."""
        return self.slave.min_conditioning if config.singularity_halt is None else config.singularity_halt

    def warm_up(self, c: TeleopConfig) -> None:
        """Load (or compile) the guard kernels now, for the argument types of a real step, so
        that the first engaged step does not wait for numba."""
        g = self.slave
        p, q = np.array(g.home_position, dtype=float), np.array(g.home_quaternion_xyzw, dtype=float)
        m = pose_margins(g, p, q)
        home = GuardedCommand.at(p, q, m.lengths, m, g.min_conditioning)
        halt = self.halt(c)
        self.loads.warm_up(home, halt)
        self.kernels.mapped_pose(p, q, p.copy(), q.copy(), p.copy(), q.copy(), c.translation_scale,
                                 False, np.empty(3), np.empty(4))
        self.kernels.guarded_cartesian_step(
            self._limit_arrays, home.buffer, p, q, 0.0, 0.0, 0.0, LEG_SPEED_ITERATIONS,
            c.singularity_slowdown, halt, c.collision_slowdown, np.empty(COMMAND_SIZE))
        self.kernels.guarded_joint_step(
            self._limit_arrays, 1.0 / g.characteristic_length, home.buffer, m.lengths * 1.0, 0.0,
            c.singularity_slowdown, halt, c.collision_slowdown, np.empty(COMMAND_SIZE))

    def cartesian(self, command: GuardedCommand, p1: np.ndarray, q1: np.ndarray, dt: float,
                  c: TeleopConfig) -> tuple[GuardedCommand, TeleopCode, str]:
        """The step of ``dt`` [s] from ``command`` towards the pose (p1, q1)."""
        buffer = np.empty(COMMAND_SIZE)
        outcome, limit, check, index = self.kernels.guarded_cartesian_step(
            self._limit_arrays, command.buffer, p1, q1, c.max_linear_speed * dt,
            c.max_angular_speed * dt, self.slave.max_speed * dt, LEG_SPEED_ITERATIONS,
            c.singularity_slowdown, self.halt(c), c.collision_slowdown, buffer)
        return self._conclude(command, outcome, limit, check, index,
                              GuardedCommand(buffer, self.slave.min_conditioning), c)

    def joint(self, command: GuardedCommand, L1: np.ndarray, dt: float,
              c: TeleopConfig) -> tuple[GuardedCommand, TeleopCode, str]:
        """The step of ``dt`` [s] from ``command`` towards the leg lengths ``L1``."""
        buffer = np.empty(COMMAND_SIZE)
        outcome, limit, check, index = self.kernels.guarded_joint_step(
            self._limit_arrays, 1.0 / self.slave.characteristic_length, command.buffer, L1,
            self.slave.max_speed * dt, c.singularity_slowdown, self.halt(c), c.collision_slowdown, buffer)
        return self._conclude(command, outcome, limit, check, index,
                              GuardedCommand(buffer, self.slave.min_conditioning), c)

    def _conclude(self, command: GuardedCommand, outcome: int, limit: int, check: int, index: int,
                  cand: GuardedCommand, c: TeleopConfig) -> tuple[GuardedCommand, TeleopCode, str]:
        """The candidate of an accepted step (else ``command``); the status code and detail of any step."""
        if outcome == STEP_UNCHANGED:
            return command, TeleopCode.NO_WARNING, ''
        if outcome == STEP_FK_FAILED:
            return command, TeleopCode.INVALID, 'FK of the mapped leg lengths did not converge: holding'
        if outcome == STEP_REFUSED:
            name, halt_code = _CHECKS[check]
            if check == CHECK_CONDITIONING:
                value = cand.margins.inverse_condition - self.halt(c)
            else:
                value = cand.buffer[CHECK_STARTS[check] + index]
            return command, halt_code, f'{name} margin {float(value):.4g} would be negative: holding'
        code = _LIMIT_CODES[limit]
        if c.load_guards:
            cand, code, detail = self.loads.step(command, cand, code, c, self.halt(c), joint=c.mode == 'joint')
            if cand is None:
                return command, code, detail
        return cand, code, ''


#: Name and halt code of each check (CHECK_* order).
_CHECKS = (('stroke', TeleopCode.JOINT_BOUND), ('universal joint', TeleopCode.JOINT_BOUND),
           ('spherical joint', TeleopCode.JOINT_BOUND), ('interference', TeleopCode.HALT_FOR_COLLISION),
           ('conditioning', TeleopCode.HALT_FOR_SINGULARITY))
#: The status code of an accepted step, by what limited it (LIMIT_* order).
_LIMIT_CODES = (TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED,
                TeleopCode.DECELERATE_FOR_APPROACHING_SINGULARITY, TeleopCode.HALT_FOR_SINGULARITY,
                TeleopCode.DECELERATE_FOR_COLLISION, TeleopCode.HALT_FOR_COLLISION)
