"""Legs in phase: a jerk-limited motion of n actuators along one line of their joint space,
planned by Ruckig as one degree of freedom, so that each leg's profile is that profile scaled by
the leg's share of the line, and the pose keeps its path.

Ruckig's own phase synchronisation does the same for n degrees of freedom when their state and
target lie on one line, but falls back to time synchronisation (each leg its own profile shape,
the pose off its path) without saying so, also on inputs collinear to 1e-14: measured on the
driver's setpoints, with the leading leg at its acceleration limit while its velocity reverses.
One degree of freedom along the line cannot leave it. Pure Python and NumPy (and ruckig); no
ROS import.
"""

from __future__ import annotations

import numpy as np
import ruckig

from rrps_description.motion_limits import ActuatorLimits

__all__ = ['IN_PHASE', 'phase_line', 'LineMotion']

#: Velocity and acceleration that leave one line by less than this (relative to their size) are
#: on it: the legs move in phase.
IN_PHASE = 1e-9


def phase_line(velocity: np.ndarray, acceleration: np.ndarray, shed: float = 0.0) -> np.ndarray | None:
    """The unit vector of the line the legs move on, when their velocity and acceleration lie on
    one line (in phase), or their acceleration leaves the velocity's line by at most ``shed``
    [m/s^2] (what the jerk limit sheds in one period: a motion along the line drops it within
    the limit); None at rest or out of phase."""
    motion = velocity if np.any(velocity) else acceleration
    norm = float(np.linalg.norm(motion))
    if norm == 0.0:
        return None
    u = motion / norm
    across = max(np.linalg.norm(velocity - (velocity @ u) * u), np.linalg.norm(acceleration - (acceleration @ u) * u))
    return u if across <= max(IN_PHASE * (norm + np.linalg.norm(acceleration)), shed) else None


class LineMotion:
    """Moves legs within ``limits`` along a line ``u`` (a unit vector of their space): one Ruckig
    degree of freedom s, the legs at position + s u; its limits the legs' divided by the largest
    share max |u_i|, so that the leading leg reaches its own."""

    def __init__(self, limits: ActuatorLimits):
        self.limits = limits
        self._otg = ruckig.Ruckig(1)
        self._input = ruckig.InputParameter(1)
        self._output = ruckig.OutputParameter(1)

    def step(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, u: np.ndarray,
             dt: float, *, target_velocity: float | None = None, distance: float | None = None,
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """The legs' (position, velocity, acceleration) ``dt`` [s] on, and whether the motion is
        finished: to ``target_velocity`` [m/s along u] (Ruckig's velocity interface), or at rest
        ``distance`` [m] along u (its position interface). The state's acceleration across the
        line is dropped, this period's jerk limit lowered by as much (see :func:`phase_line`)."""
        share = float(np.max(np.abs(u)))
        lim, inp, out = self.limits, self._input, self._output
        # the acceleration across the line is dropped in this period: within the jerk limit with the line's
        shed = float(np.max(np.abs(acceleration - (acceleration @ u) * u))) / dt
        if shed >= lim.jerk:
            raise ValueError(f'the acceleration across the line ({shed * dt:.3g} m/s^2) exceeds one period of jerk')
        inp.max_velocity, inp.max_acceleration = [lim.speed / share], [lim.acceleration / share]
        inp.max_jerk = [(lim.jerk - shed) / share]
        inp.current_position = [0.0]
        inp.current_velocity, inp.current_acceleration = [float(velocity @ u)], [float(acceleration @ u)]
        inp.target_velocity = inp.target_acceleration = [0.0]
        if distance is None:
            inp.control_interface = ruckig.ControlInterface.Velocity
            inp.target_velocity = [float(target_velocity)]
        else:
            inp.control_interface = ruckig.ControlInterface.Position
            inp.target_position = [float(distance)]
        self._otg.delta_time = dt
        finished = self._otg.update(inp, out) == ruckig.Result.Finished
        s, v, a = out.new_position[0], out.new_velocity[0], out.new_acceleration[0]
        return position + s * u, v * u, a * u, finished
