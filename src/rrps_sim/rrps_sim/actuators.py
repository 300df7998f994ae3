"""Actuator models of the simulated hardware: dynamic (PD on eq. 19), the quasi-static efforts of
position-controlled legs and sensor faults (the kinematic ones: :mod:`rrps_sim.kinematic_actuators`).

Pure NumPy, no ROS import. Lengths [m], speeds [m/s], efforts [N], ``dt`` [s]. Both compute in the
world gravity of the supporting ring's attitude and follow a gripper change with ``set_support``;
``stuck`` axes ignore commands; the driver applies :class:`SensorFaults` to what it publishes.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.world import Support, handed_over
from rrps_kinematics.forward import forward_kinematics
from rrps_loads.statics import holding_forces
from rrps_sim.dynamics import MultibodyDynamics
from rrps_sim.kinematic_actuators import KinematicActuators

__all__ = ['DynamicActuators', 'QuasiStaticEfforts', 'SensorFaults']


class DynamicActuators:
    """The six legs as force actuators on the multibody dynamics (eqs. 19-20).

    Each leg's force ``f = f_g + kp (r - L) + kd (r' - L')`` [N], saturated at ``max_force``, with
    ``f_g`` the gravity feed-forward (:func:`rrps_loads.statics.holding_forces`); ``efforts`` = forces."""

    def __init__(self, geometry: RobotGeometry, initial_lengths, *, kp: float = 1.0e5,
                 kd: float = 1.0e3, time_constant: float = 0.0, max_speed: float | None = None,
                 max_step: float = 1e-3, feedforward_period: float = 0.02, method: str = 'hybrid',
                 support: Support | None = None):
        for name, value in (('kp', kp), ('kd', kd)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value}')
        if not (math.isfinite(max_step) and max_step > 0.0):
            raise ValueError(f'max_step must be > 0, got {max_step}')
        if not (math.isfinite(feedforward_period) and feedforward_period >= 0.0):
            raise ValueError(f'feedforward_period must be >= 0, got {feedforward_period}')
        self.geometry = geometry
        L0 = np.asarray(initial_lengths, dtype=float)
        fk = forward_kinematics(geometry, L0)
        if not fk.converged:
            raise ValueError(f'initial lengths {L0} do not assemble near the home pose')
        self.dynamics = MultibodyDynamics(geometry, method, support=support or Support.of())
        self.dynamics.reset(fk.position, fk.quaternion_xyzw)
        self.reference = KinematicActuators(
            geometry.min_length, geometry.max_length,
            geometry.max_speed if max_speed is None else max_speed, time_constant, L0)
        self.kp, self.kd = float(kp), float(kd)
        self.max_step = float(max_step)
        self.feedforward_period = float(feedforward_period)
        self.forces = np.zeros(6)
        self._feedforward = self._holding_forces(np.zeros(6))
        self._since_feedforward = 0.0

    @property
    def stuck(self) -> np.ndarray:
        return self.reference.stuck

    @stuck.setter
    def stuck(self, value) -> None:
        self.reference.stuck = np.asarray(value, dtype=bool)

    @property
    def positions(self) -> np.ndarray:
        return self.dynamics.lengths

    @property
    def velocities(self) -> np.ndarray:
        return self.dynamics.length_rates

    @property
    def efforts(self) -> np.ndarray:
        return self.forces.copy()

    @property
    def support(self) -> Support:
        return self.dynamics.support

    def set_support(self, ring: str | Support) -> None:
        """``ring`` alone grips now: ground it in the dynamics (:func:`handed_over`); or ground
        a :class:`Support` as given (its attitude from the odometry), at rest."""
        support = ring if isinstance(ring, Support) else handed_over(self.support, self.dynamics.quaternion_xyzw, ring)
        if support is not self.support:
            self.dynamics.set_support(support)
            self._feedforward = self._holding_forces(self._feedforward)

    def _holding_forces(self, fallback: np.ndarray) -> np.ndarray:
        try:
            return holding_forces(self.geometry, self.dynamics.position, self.dynamics.quaternion_xyzw,
                                  support=self.support)
        except ValueError:  # singular pose: keep the previous feed-forward
            return fallback

    def step(self, reference, dt: float) -> None:
        """Advance by ``dt`` s toward the reference lengths (6,).

        Raises RuntimeError (from the dynamics) at a singular configuration; the state is then
        left as it was at the start of the failing sub-step.
        """
        self.reference.step(reference, dt)
        if dt == 0.0:
            return
        r, rdot = self.reference.positions, self.reference.velocities
        n = max(1, math.ceil(dt / self.max_step - 1e-9))
        h = dt / n
        limit = self.geometry.max_force
        for _ in range(n):
            if self.feedforward_period > 0.0 and self._since_feedforward >= self.feedforward_period:
                self._feedforward = self._holding_forces(self._feedforward)
                self._since_feedforward = 0.0
            dyn = self.dynamics
            f = self._feedforward + self.kp * (r - dyn.lengths) + self.kd * (rdot - dyn.length_rates)
            f = np.clip(f, -limit, limit)
            dyn.step(f, h)
            self.forces = f
            self._since_feedforward += h


class QuasiStaticEfforts:
    """Efforts [N] of position-controlled actuators: the statics of eq. 19 at the pose found by FK,
    refreshed at most every ``period`` s; a pose where FK or the statics fail keeps the previous ones."""

    def __init__(self, geometry: RobotGeometry, initial_lengths, *, period: float = 0.2,
                 support: Support | None = None):
        if not (math.isfinite(period) and period >= 0.0):
            raise ValueError(f'period must be finite and >= 0, got {period}')
        self.geometry = geometry
        self.support = support or Support.of()
        self.period = float(period)
        self._position = geometry.home_position
        self._quaternion = geometry.home_quaternion_xyzw
        self.efforts = np.zeros(6)
        self._since = 0.0
        self._refresh(np.asarray(initial_lengths, dtype=float))

    def _refresh(self, lengths: np.ndarray) -> None:
        fk = forward_kinematics(self.geometry, lengths, self._position, self._quaternion)
        if not fk.converged:
            return
        self._position, self._quaternion = fk.position, fk.quaternion_xyzw
        try:
            self.efforts = holding_forces(self.geometry, fk.position, fk.quaternion_xyzw, support=self.support)
        except ValueError:
            pass

    def set_support(self, ring: str | Support) -> None:
        """``ring`` alone grips now (:func:`handed_over` at the last refreshed pose), or a
        :class:`Support` as given (its attitude from the odometry); the efforts are solved again
        at once."""
        support = ring if isinstance(ring, Support) else handed_over(self.support, self._quaternion, ring)
        if support is not self.support:
            self.support = support
            self._since = self.period

    def update(self, lengths, dt: float) -> np.ndarray:
        """Advance the refresh clock by ``dt`` s; re-solve when ``period`` has passed."""
        self._since += dt
        if self._since >= self.period:
            self._since = 0.0
            self._refresh(np.asarray(lengths, dtype=float))
        return self.efforts


class SensorFaults:
    """Faults of the measurement path: Gaussian noise (std ``noise`` [m]) on the published
    lengths and a probability ``drop_probability`` of dropping a state message. Seeded."""

    def __init__(self, noise: float = 0.0, drop_probability: float = 0.0, seed: int | None = None):
        if not (math.isfinite(noise) and noise >= 0.0):
            raise ValueError(f'noise must be finite and >= 0, got {noise}')
        if not (0.0 <= drop_probability <= 1.0):
            raise ValueError(f'drop_probability must be in [0, 1], got {drop_probability}')
        self.noise = float(noise)
        self.drop_probability = float(drop_probability)
        self._rng = np.random.default_rng(seed)

    def measure(self, positions: np.ndarray) -> np.ndarray:
        """The positions as the sensors report them."""
        if self.noise == 0.0:
            return positions
        return positions + self._rng.normal(0.0, self.noise, np.shape(positions))

    def drop(self) -> bool:
        """True when this message is lost."""
        return self.drop_probability > 0.0 and bool(self._rng.random() < self.drop_probability)
