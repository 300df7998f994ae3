"""A paused stream's stop along its path: the path's time rate r falls from 1 to 0 in the shortest
time a jerk-limited profile allows, so the legs slow down on the planned path instead of the stream
stopping at speed (which the driver's jerk-limited setpoints overshoot and come back from, off the path).

A leg at speed v along the path gets the extra acceleration r' v and jerk r'' v; so r' <= a / v and
r'' <= j / v keep it within the stream's limits at its speed limit. Ruckig's velocity interface gives
the time-optimal profile of r from 1 to 0 within them, at rest in acceleration at both ends; it is
point-symmetric about its middle, so the path time goes on by T/2 in all.
"""

from __future__ import annotations

import ruckig

from rrps_description.motion_limits import ActuatorLimits

__all__ = ['PathBrake', 'brake_time']


class PathBrake:
    """The path rate's time-optimal jerk-limited fall from 1 to 0 within ``limits`` (at their speed)."""

    def __init__(self, limits: ActuatorLimits):
        v, a, j = limits.speed, limits.acceleration, limits.jerk
        inp = ruckig.InputParameter(1)
        inp.control_interface = ruckig.ControlInterface.Velocity
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [1.0], [0.0]
        inp.target_velocity, inp.target_acceleration = [0.0], [0.0]
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1.0], [a / v], [j / v]
        self._trajectory = ruckig.Trajectory(1)
        result = ruckig.Ruckig(1).calculate(inp, self._trajectory)
        if result != ruckig.Result.Working:
            raise ValueError(f'no brake within {limits}: ruckig {result}')

    @property
    def duration(self) -> float:
        """How long [s] the rate takes to fall to 0."""
        return float(self._trajectory.duration)

    def path_time(self, tau: float) -> float:
        """How far [s] the path time went on ``tau`` [s] into the brake (duration/2 at its end)."""
        position, _, _ = self._trajectory.at_time(min(max(float(tau), 0.0), self.duration))
        return float(position[0])


def brake_time(limits: ActuatorLimits) -> float:
    """The duration [s] of a brake from ``limits``' speed within its acceleration and jerk."""
    return PathBrake(limits).duration
