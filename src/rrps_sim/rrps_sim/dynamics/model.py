"""The 13-body forward dynamics of one robot (eqs. 19-20) on either ring, stepped by the caller;
coordinates in the supporting ring's frame, poses in and out a_T_b."""

from __future__ import annotations

import math
import time
from typing import Callable, NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_kinematics.errors import ConvergenceError, SingularPoseError
from rrps_kinematics.multibody import MultibodyModel
from rrps_loads.support import support_of
from rrps_sim.dynamics.bundles import DynamicsParameters, Observation, Observations, Reactions, new_workspace, workspace
from rrps_sim.dynamics.constraints import leg_blocks
from rrps_sim.dynamics.driven import DriveLoop, driven_run
from rrps_sim.dynamics.flops import step_flops
from rrps_sim.dynamics.frames import grounded_coordinates, supported_pose
from rrps_sim.dynamics.integrators import METHODS, NOT_CONVERGED, run, step
from rrps_sim.dynamics.kernels import applied_forces, reactions_into
from rrps_sim.dynamics.observation import observe

__all__ = ['MultibodyDynamics', 'RunRecord']

#: A compiled run is cut into about this many batches, timed one by one: with a progress
#: callback (called after each batch), else without.
RUN_BATCHES = 100
RUN_BATCHES_UNWATCHED = 10


class RunRecord(NamedTuple):
    """What :meth:`MultibodyDynamics.run` records: ``t`` (R,) [s], ``observed``
    (:class:`~rrps_sim.dynamics.bundles.Observations`, R rows) and ``actuator_work`` (R,) [J] of
    the start (row 0) and of each output step; ``step_flops`` (S,) and ``step_seconds`` (S,) of
    every step (flop model, wall time); ``reactions`` (:class:`~.bundles.Reactions`, R rows)
    when asked for, else None."""

    t: np.ndarray
    observed: Observations
    actuator_work: np.ndarray
    step_flops: np.ndarray
    step_seconds: np.ndarray
    reactions: Reactions | None = None


class MultibodyDynamics:
    """Forward dynamics of one robot (eqs. 19-20), stepped by the caller.

    ``method``: 'baumgarte', 'partitioning' or 'hybrid'; ``alpha``, ``beta`` [1/s] the Baumgarte gains.
    ``support`` is the gripping ring, in the world of :func:`rrps_loads.support.support_of`."""

    def __init__(self, geometry: RobotGeometry, method: str = 'hybrid', *, alpha: float = 10.0,
                 beta: float = 10.0, correction_tolerance: float = 1e-10,
                 newton_tolerance: float = 1e-13, max_newton_iterations: int = 20,
                 support='ring_a', world_q_support=None, gravity=None):
        if method not in METHODS:
            raise ValueError(f'method must be one of {METHODS}, got {method!r}')
        for name, value in (('alpha', alpha), ('beta', beta)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value}')
        self.geometry = geometry
        self.method = method
        self._method = METHODS.index(method)
        self.alpha = float(alpha)
        self.beta = float(beta)
        self.correction_tolerance = float(correction_tolerance)
        self.newton_tolerance = float(newton_tolerance)
        self.max_newton_iterations = int(max_newton_iterations)
        self.model = MultibodyModel(geometry)
        self._buffer = new_workspace()
        self._ground(support_of(support, world_q_support, gravity))
        self.corrections = 0
        self.last_step_flops = 0
        self.reset(geometry.home_position, geometry.home_quaternion_xyzw)

    def _ground(self, support) -> None:
        self.support = support
        self._params = DynamicsParameters.of(self.geometry, support)
        for a in self._params:
            if isinstance(a, np.ndarray):
                a.flags.writeable = False

    def set_support(self, support, world_q_support=None, gravity=None) -> None:
        """Ground the other ring (or turn the world) at the current pose, at rest: what a
        gripper change does, both grippers closed. Time and actuator work carry on."""
        position, quaternion = self.position, self.quaternion_xyzw
        self._ground(support_of(support, world_q_support, gravity))
        work, t = self.actuator_work, self.time
        self.reset(position, quaternion)
        self.actuator_work, self.time = work, t
        self._energy0 -= work

    # --- what the kernels see ---

    @property
    def parameters(self) -> DynamicsParameters:
        """The robot as the compiled kernels take it (read-only arrays)."""
        return self._params

    @property
    def mass(self) -> np.ndarray:
        """Body masses (13,) [kg]: the hub (ring_b with ring_a grounded), then each leg's lower
        and upper link."""
        return self._params.mass

    @property
    def inertia(self) -> np.ndarray:
        """Body inertias J' (13, 3, 3) about each com, in the body frame [kg m^2]."""
        return self._params.inertia

    # --- state ---

    @property
    def q(self) -> np.ndarray:
        """A copy of the 91 coordinates, in the supporting ring's frame (:meth:`set_state`)."""
        return self._q.copy()

    @property
    def v(self) -> np.ndarray:
        """A copy of the 78 velocities [ṙ, ω'] per body (:meth:`set_state` changes them)."""
        return self._v.copy()

    def set_state(self, q, v) -> None:
        """Replace the state (91 coordinates, 78 velocities) as given, consistent or not."""
        q = np.array(q, dtype=float)
        v = np.array(v, dtype=float)
        if q.shape != (91,) or v.shape != (78,):
            raise ValueError(f'q and v must have shapes (91,), (78,), got {q.shape}, {v.shape}')
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
            raise ValueError('q and v must be finite')
        self._q, self._v = q, v
        self._obs = None

    def reset(self, position, quaternion_xyzw) -> None:
        """At rest at the pose a_T_b (all joint constraints satisfied, zero velocities)."""
        self._q = self._coordinates(position, quaternion_xyzw)
        self._v = np.zeros(78)
        self._obs = None
        self.time = 0.0
        self.actuator_work = 0.0
        self.corrections = 0
        self.last_step_flops = 0
        self._energy0 = self.kinetic_energy + self.potential_energy

    def _coordinates(self, position, quaternion_xyzw) -> np.ndarray:
        """Consistent q (91,) for a_T_b, in the supporting ring's frame."""
        return grounded_coordinates(self.model.coordinates_from_pose(position, quaternion_xyzw),
                                    self.support, self.model.ring_b_com, self.geometry.ring_a_body.com)

    def step(self, forces, dt: float) -> None:
        """Advance by dt [s] with actuator forces (6,) [N] held over the step (+ = push apart).

        Raises ValueError for bad input, SingularPoseError if the model reaches a singular
        configuration and ConvergenceError if a dependent-coordinate solve does not converge
        (both are RuntimeErrors; the state is then left at the start of the step)."""
        f, dt = _checked(forces, dt)
        status, work, newton, corrected = step(
            self._q, self._v, self.actuator_work, f, dt, self._method, self.alpha,
            self.beta, self.correction_tolerance, self.newton_tolerance,
            self.max_newton_iterations, self._params, self._buffer)
        self.corrections += int(corrected)
        self._raise_for(status)
        self._obs = None
        self.actuator_work = float(work)
        self.time += dt
        self.last_step_flops = step_flops(self.method, self.alpha != 0.0 or self.beta != 0.0,
                                          newton, int(corrected), self.support.index)

    def run(self, forces, dt: float, steps: int, *, output_every: int = 1,
            progress: Callable[[float], None] | None = None, reactions: bool = False) -> RunRecord:
        """``steps`` steps of ``dt`` [s] with constant ``forces`` (6,) [N], compiled as one loop, recording
        every ``output_every``-th step and the last (with joint reactions if ``reactions``). Raises as
        :meth:`step` (the state is then that before the failing step)."""
        f, dt = _checked(forces, dt)
        steps, output_every = int(steps), int(output_every)
        if steps < 1 or output_every < 1:
            raise ValueError(f'steps and output_every must be >= 1, got {steps}, {output_every}')
        rows = 1 + -(-steps // output_every)
        observed = Observations.empty(rows)
        for field, value in zip(observed, self.observation):
            field[0] = value
        work = np.empty(rows)
        work[0] = self.actuator_work
        recorded = Reactions.empty(rows if reactions else 1)
        if reactions:
            for field, value in zip(recorded, self.reactions(f)):
                field[0] = value
        newton = np.zeros(steps, dtype=np.int64)
        corrected = np.zeros(steps, dtype=np.bool_)
        seconds = np.empty(steps)
        batch = max(1, steps // (RUN_BATCHES if progress is not None else RUN_BATCHES_UNWATCHED))
        settings = (self._method, self.alpha, self.beta, self.correction_tolerance,
                    self.newton_tolerance, self.max_newton_iterations)
        t0 = self.time
        done = 0
        while done < steps:
            last = min(steps, done + batch)
            start = time.perf_counter()
            status, self.actuator_work, failed = run(
                self._q, self._v, self.actuator_work, f, dt, done, last, output_every, *settings,
                self._params, self._buffer, observed, work, newton, corrected, reactions, recorded)
            seconds[done:last] = (time.perf_counter() - start) / (last - done)
            self.time = t0 + failed * dt
            self.corrections += int(np.count_nonzero(corrected[done:min(failed + 1, last)]))
            self._obs = None
            self._raise_for(status)
            done = last
            if progress is not None:
                progress(done / steps)
        flops = step_flops(self.method, self.alpha != 0.0 or self.beta != 0.0, newton, corrected,
                           self.support.index)
        self.last_step_flops = int(flops[-1])
        ends = np.minimum(np.arange(rows) * output_every, steps)
        return RunRecord(t0 + ends * dt, observed, work, flops, seconds, recorded if reactions else None)

    def run_driven(self, commands: np.ndarray, period: float, t0: float, steps: int, dt: float,
                   drive: DriveLoop, reference: np.ndarray, feedforward, forces: np.ndarray,
                   peak: np.ndarray) -> None:
        """``steps`` steps of ``dt`` [s] with the legs driven by ``drive`` toward the commanded
        lengths ``commands`` (n, 6) [m], one every ``period`` [s] from the motion's time ``t0``
        [s], compiled as one loop (:func:`.driven.driven_run`: ``reference`` (12,), ``forces``
        and ``peak`` (6,) updated in place; ``feedforward`` (6,) [N]). Raises as :meth:`step`."""
        ff, dt = _checked(feedforward, dt)
        status, self.actuator_work, done = driven_run(
            self._q, self._v, self.actuator_work, commands, float(period), float(t0), int(steps), dt,
            drive, reference, ff, forces, peak, self._method, self.alpha, self.beta,
            self.correction_tolerance, self.newton_tolerance, self.max_newton_iterations,
            self._params, self._buffer)
        self.time += done * dt
        self._obs = None
        self._raise_for(status)

    def _raise_for(self, status: int) -> None:
        """The exception of a failed step's status code (nothing for 0)."""
        if status == NOT_CONVERGED:
            raise ConvergenceError(
                f'no convergence at t = {self.time:.6f} s: the dependent coordinates did not '
                f'converge in {self.max_newton_iterations} Newton iterations')
        if status != 0:
            raise SingularPoseError(f'singular configuration at t = {self.time:.6f} s: eq. 19 '
                                    f'has no solution (a leg lost rank)')

    @property
    def observation(self) -> Observation:
        """Everything reported of the current state (computed once per state)."""
        if self._obs is None:
            self._obs = observe(self._q, self._v, self._params, self._buffer)
        return self._obs

    @property
    def pose(self) -> Pose:
        """a_T_b: ring_b's pose in ring_a's frame."""
        return Pose(*supported_pose(self.observation.position, self.observation.euler_parameters,
                                    self.support))

    @property
    def position(self) -> np.ndarray:
        """ring_b's origin in ring_a's frame [m]."""
        return self.pose.position.copy()

    @property
    def quaternion_xyzw(self) -> np.ndarray:
        """ring_b's orientation in ring_a's frame (x, y, z, w), w >= 0."""
        return self.pose.quaternion_xyzw.copy()

    @property
    def lengths(self) -> np.ndarray:
        """Actuator lengths [m]."""
        return self.observation.lengths.copy()

    @property
    def length_rates(self) -> np.ndarray:
        """Actuator velocities [m/s]."""
        return self.observation.length_rates.copy()

    @property
    def constraint_drift(self) -> float:
        """‖Φ^K(q)‖, the 2-norm of the 72 joint constraints."""
        return float(self.observation.constraint_drift)

    @property
    def euler_norm_error(self) -> float:
        """max over bodies of |p^T p - 1| (eq. 9)."""
        return float(self.observation.euler_norm_error)

    @property
    def kinetic_energy(self) -> float:
        """Σ ½ m |ṙ|² + ½ ω'^T J' ω' [J]."""
        return float(self.observation.kinetic)

    @property
    def potential_energy(self) -> float:
        """-Σ m g·r [J] (zero at the supporting ring's origin)."""
        return float(self.observation.potential)

    @property
    def initial_energy(self) -> float:
        """Kinetic + potential energy at the last :meth:`reset` [J]."""
        return self._energy0

    @property
    def energy_balance(self) -> float:
        """Kinetic + potential - actuator work, minus its initial value [J] (0 if exact)."""
        return self.kinetic_energy + self.potential_energy - self.actuator_work - self._energy0

    # --- joint reactions and statics from the Lagrange multipliers ---

    def reactions(self, forces) -> Reactions:
        """The joint reactions (:class:`~.bundles.Reactions`, one row, in the supporting ring's
        frame) of the current state under actuator ``forces`` (6,) [N], from the multipliers
        of eq. 19. Raises SingularPoseError where eq. 19 has no solution."""
        f, _ = _checked(forces, 1.0)
        out = Reactions.empty(1)
        if not reactions_into(self._q, self._v, f, self._params, workspace(self._buffer), out, 0):
            raise SingularPoseError(f'singular configuration at t = {self.time:.6f} s: eq. 19 '
                                    f'has no solution (a leg lost rank)')
        return Reactions(*(field[0] for field in out))

    def holding_forces(self, position, quaternion_xyzw) -> np.ndarray:
        """Actuator forces [N] (+ = push apart) that hold the robot at rest at a pose a_T_b.

        At rest eq. 19 with the 6 driving constraints (eq. 10) added reads Φ_x^T λ = F^A
        (78 x 78: gravity and the tool wrench); the driving multipliers are the actuator forces:
        f = -λ_D. Raises SingularPoseError (a ValueError) at a singular pose."""
        q = self._coordinates(position, quaternion_xyzw)
        v = np.zeros(78)
        Phi = np.zeros((78, 78))
        B = np.empty((13, 18))
        gamma = np.empty(13)
        for k in range(6):
            leg_blocks(q, v, k, self._params.joints, self._params.support, B, gamma)
            cols = np.r_[0:6, 6 * (1 + 2 * k):6 * (1 + 2 * k) + 12]
            Phi[12 * k:12 * k + 12, cols] = B[:12]
            Phi[72 + k, cols] = B[12]
        F = np.zeros(78)
        applied_forces(q, v, self._params, np.empty((13, 3, 3)), F)
        try:
            lam = np.linalg.solve(Phi.T, F)
        except np.linalg.LinAlgError:
            raise SingularPoseError('singular pose: no finite holding forces') from None
        if not np.all(np.isfinite(lam)) or np.linalg.cond(Phi) > 1e12:
            raise SingularPoseError('singular pose: no finite holding forces')
        return -lam[72:78]


def _checked(forces, dt) -> tuple[np.ndarray, float]:
    """Actuator forces (6,) [N] and a step [s] as the kernels take them; ValueError if invalid."""
    f = np.ascontiguousarray(forces, dtype=float)
    if f.shape != (6,) or not np.all(np.isfinite(f)):
        raise ValueError(f'forces must be 6 finite numbers [N], got shape {f.shape}')
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f'dt must be a positive finite number of seconds, got {dt}')
    return f, dt
