"""Teleop's stream of targets, jerk-limited: the guarded commands reached by Ruckig (Berscheid and
Kröger, RSS 2021) in the legs' lengths, so the stream starts and stops without a velocity jump.

:meth:`TargetStream.follow` plans each step the time-optimal motion of the six lengths to the
newest guarded command at rest within the legs' stream limits
(:func:`~rrps_description.motion_limits.stream_limits`); the target pose is the FK of the
stream's lengths. :meth:`TargetStream.stop` is the fastest jerk-limited stop
(:func:`stopping_time`, :func:`stopping_distance`, from speed v at zero acceleration:
2 sqrt(v / j) for v <= a_max² / j, else v / a_max + a_max / j). Pure NumPy (and ruckig).
"""

from __future__ import annotations

import math

import numpy as np
import ruckig

from rrps_description.geometry import RobotGeometry
from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_kinematics.forward import ForwardSolver

__all__ = ['TargetStream', 'stopping_time', 'stopping_distance']


def stopping_time(speed: float, limits: ActuatorLimits) -> float:
    """The fastest jerk-limited stop [s] from ``speed`` [m/s] at zero acceleration (module docstring)."""
    v, a, j = abs(speed), limits.acceleration, limits.jerk
    return 2.0 * math.sqrt(v / j) if v <= a * a / j else v / a + a / j


def stopping_distance(speed: float, limits: ActuatorLimits) -> float:
    """The distance [m] of that stop: v t / 2 by the stop's symmetry in time."""
    return 0.5 * abs(speed) * stopping_time(speed, limits)


class TargetStream:
    """The jerk-limited stream of targets of ``geometry``'s legs (module docstring)."""

    def __init__(self, geometry: RobotGeometry):
        self.limits = stream_limits(geometry.motion_limits.legs)
        self._fk = ForwardSolver(geometry)
        self._otg = ruckig.Ruckig(6, 0.01)
        self._input = ruckig.InputParameter(6)
        self._output = ruckig.OutputParameter(6)
        self._input.max_velocity = [self.limits.speed] * 6
        self._input.max_acceleration = [self.limits.acceleration] * 6
        self._input.max_jerk = [self.limits.jerk] * 6
        self.lengths: np.ndarray | None = None   # the stream's state; None: it does not stream
        self.velocity = np.zeros(6)
        self.acceleration = np.zeros(6)
        self.pose: tuple[np.ndarray, np.ndarray] | None = None
        self._time = 0.0

    @property
    def moving(self) -> bool:
        """The stream is not at rest (a stop still streams)."""
        return self.lengths is not None and bool(np.any(self.velocity) or np.any(self.acceleration))

    def follow(self, t: float, lengths, position, quaternion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stream at ``t`` [s] towards the guarded command (``lengths``, its pose
        ``position``, ``quaternion``): (lengths, position, quaternion). From rest a new stream
        starts at the command (after :meth:`reset`: an engage, the slave's own pose)."""
        lengths = np.asarray(lengths, dtype=float)
        if self.lengths is None:
            return self._at(t, lengths, position, quaternion)
        inp = self._input
        inp.control_interface = ruckig.ControlInterface.Position
        inp.target_position = lengths.tolist()
        inp.target_velocity = inp.target_acceleration = [0.0] * 6
        if not self._update(t) or np.array_equal(self.lengths, lengths):
            return self._at(t, lengths, position, quaternion)
        return self._solved()

    def stop(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The stream at ``t`` [s] braking to rest as fast as the limits allow; None once at rest
        (nothing more to send)."""
        if not self.moving:
            return None
        inp = self._input
        inp.control_interface = ruckig.ControlInterface.Velocity
        inp.target_velocity = inp.target_acceleration = [0.0] * 6
        if not self._update(t):
            self.velocity, self.acceleration = np.zeros(6), np.zeros(6)
        return self._solved()

    def reset(self) -> None:
        """No stream: the next :meth:`follow` starts one at rest at its command."""
        self.lengths, self.pose = None, None
        self.velocity, self.acceleration = np.zeros(6), np.zeros(6)

    def _at(self, t: float, lengths, position, quaternion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """At rest exactly on the command."""
        self.lengths, self._time = lengths.copy(), float(t)
        self.velocity, self.acceleration = np.zeros(6), np.zeros(6)
        self.pose = (np.array(position, dtype=float), np.array(quaternion, dtype=float))
        return self.lengths.copy(), self.pose[0].copy(), self.pose[1].copy()

    def _update(self, t: float) -> bool:
        """One Ruckig step of the time since the last; False when it arrived (or cannot plan)."""
        dt = max(float(t) - self._time, 0.0)   # the stream is a function of time: a late step takes its time's
        self._time = float(t)
        if dt <= 0.0:
            return True
        inp, out = self._input, self._output
        inp.current_position, inp.current_velocity = self.lengths.tolist(), self.velocity.tolist()
        inp.current_acceleration = self.acceleration.tolist()
        self._otg.delta_time = dt
        try:
            result = self._otg.update(inp, out)
        except ruckig.RuckigError:   # a state Ruckig cannot start from: the stream ends where it is
            return False
        self.lengths = np.array(out.new_position)
        self.velocity, self.acceleration = np.array(out.new_velocity), np.array(out.new_acceleration)
        return result != ruckig.Result.Finished

    def _solved(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stream's lengths and their pose (forward kinematics, warm-started)."""
        seed = self.pose
        fk = self._fk(self.lengths, seed[0], seed[1])
        if bool(fk.converged):
            self.pose = (np.array(fk.position), np.array(fk.quaternion_xyzw))
        return self.lengths.copy(), self.pose[0].copy(), self.pose[1].copy()
