"""The driver's setpoints: jerk-limited, from the commands it receives, by an online trajectory
generator (Ruckig: Berscheid and Kröger, RSS 2021).

:class:`JerkLimitedSetpoints` gives a setpoint every driver period within each leg's speed,
acceleration and jerk limits: a command at rest is reached time-optimally, a stream (placed in
time by its stamps) followed one command period behind without stopping at each sample; any
stream reaches the legs within the limits. :func:`stream_setpoints`: a whole stream at once (the
step preview). How: docs/architecture.md ('rrps_hardware'). No ROS import.
"""

from __future__ import annotations

import numpy as np
import ruckig

from rrps_description.motion_limits import ActuatorLimits

__all__ = ['DRIVER_PERIOD', 'STALE_PERIODS', 'MAX_STEP_PERIODS', 'CATCH_UP_PERIODS', 'JerkLimitedSetpoints',
           'stream_setpoints']

#: The driver's period [s] (500 Hz).
DRIVER_PERIOD = 0.002
#: A command's velocity counts this many of its periods after it arrived.
STALE_PERIODS = 2.5
#: A cycle later than this many periods steps the setpoints this far only (the driver's tick, a bus'
#: SYNC cycle): the motion is delayed, never jumps.
MAX_STEP_PERIODS = 5
#: The gain [1/s] of the position error in the velocity the setpoints are steered to.
GAIN = 5.0
#: Ruckig arrives at a command at rest within this [m] of it (rounding), and the setpoints are put on
#: it exactly; farther (a long profile's end can miss it by nanometres), they reach it by a further
#: motion, since a jump of 3 nm in one period reads as 0.45 m/s³ more jerk.
ARRIVED = 1e-12
#: A stream whose velocity is further than this many periods of full acceleration from the
#: setpoints' is caught up with the legs in phase (docs/measurements.md, "Headroom for the driver's
#: setpoints").
CATCH_UP_PERIODS = 5.0


class JerkLimitedSetpoints:
    """Setpoints of ``n`` actuators within ``limits``, at rest at ``positions`` (module docstring)."""

    def __init__(self, limits: ActuatorLimits, positions):
        positions = np.asarray(positions, dtype=float)
        self.n = len(positions)
        self.limits = limits
        self._otg = ruckig.Ruckig(self.n, DRIVER_PERIOD)
        self._input = ruckig.InputParameter(self.n)
        self._output = ruckig.OutputParameter(self.n)
        self._input.max_velocity = [limits.speed] * self.n
        self._input.max_acceleration = [limits.acceleration] * self.n
        self._input.max_jerk = [limits.jerk] * self.n
        self.reset(positions)

    def reset(self, positions) -> None:
        """At rest at ``positions`` (the legs hold there); the command is forgotten."""
        positions = np.asarray(positions, dtype=float)
        self.position, self.velocity, self.acceleration = positions.copy(), np.zeros(self.n), np.zeros(self.n)
        self._commands: list = []   # the last three commands (arrival time, stamp or None, positions)
        self._history: list = []    # the same in the stream's time on the driver's clock (time, positions)
        self._arrived = -np.inf     # when the newest command arrived [s]

    def command(self, positions, time: float, stamp: float | None = None) -> None:
        """A new command of ``positions`` arrived at ``time`` [s] (the driver's clock), stamped
        ``stamp`` [s] (the time of its sample in its stream, on any clock; None: unstamped)."""
        stamp = None if stamp is None else float(stamp)
        kept = [c for c in self._commands if c[0] < time and (stamp is None or c[1] is None or c[1] < stamp)]
        self._commands = kept[-2:] + [(float(time), stamp, np.asarray(positions, dtype=float).copy())]
        self._arrived = float(time)
        if any(c[1] is None for c in self._commands):
            self._history = [(t, p) for t, _, p in self._commands]
            return
        delay = min(t - s for t, s, _ in self._commands)   # the stamps' clock to the driver's
        self._history = [(s + delay, p) for _, s, p in self._commands]

    def _target(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The commands one period behind at ``time``: position, velocity and acceleration of the
        parabola through the last three (a line through two), the newest at rest once stale."""
        zero = np.zeros(self.n)
        if not self._history:
            return self.position, zero, zero
        t_new, newest = self._history[-1]
        if len(self._history) < 2:
            return newest, zero, zero
        period = t_new - self._history[-2][0]
        if time - self._arrived > STALE_PERIODS * period:
            return newest, zero, zero
        tau = min(max(time - period, self._history[0][0]), t_new)
        (t1, p1), (t2, p2) = self._history[-2:]
        d1 = (p2 - p1) / (t2 - t1)
        if len(self._history) < 3:
            return p1 + d1 * (tau - t1), d1, zero
        t0, p0 = self._history[0]
        a = 2.0 * (d1 - (p1 - p0) / (t1 - t0)) / (t2 - t0)          # the parabola's second derivative
        v = d1 + 0.5 * a * (2.0 * tau - t1 - t2)
        return p1 + d1 * (tau - t1) + 0.5 * a * (tau - t1) * (tau - t2), v, a

    def step(self, time: float, dt: float) -> np.ndarray:
        """The setpoints ``dt`` [s] on, at ``time`` [s] (the positions (n,))."""
        if dt <= 0.0:
            return self.position.copy()
        target, velocity, acceleration = self._target(time)
        lim = self.limits
        streaming = bool(np.any(velocity) or np.any(acceleration))
        velocity = np.clip(velocity, -lim.speed, lim.speed)
        # the wanted velocity leaves room to shed the present acceleration below the speed limit
        brake = self.acceleration * np.abs(self.acceleration) / (2.0 * lim.jerk)
        # the stream's velocity once its acceleration is shed at the jerk limit (a |a| / 2j): reached at
        # zero acceleration, it keeps the setpoints' acceleration on the stream's (no lag into a stop)
        ahead = velocity + acceleration * np.abs(acceleration) / (2.0 * lim.jerk)
        wanted = _within(ahead + GAIN * (target - self.position), -lim.speed - np.minimum(brake, 0.0),
                         lim.speed - np.maximum(brake, 0.0))
        inp, out = self._input, self._output
        inp.current_position, inp.current_velocity = self.position.tolist(), self.velocity.tolist()
        inp.current_acceleration = self.acceleration.tolist()
        if streaming:   # a stream: steered along it
            inp.control_interface = ruckig.ControlInterface.Velocity
            inp.target_velocity, inp.target_acceleration = wanted.tolist(), [0.0] * self.n
            catching_up = np.max(np.abs(velocity - self.velocity)) > CATCH_UP_PERIODS * lim.acceleration * DRIVER_PERIOD
            inp.synchronization = ruckig.Synchronization.Phase if catching_up else ruckig.Synchronization.No
        else:           # a command at rest: reached time-optimally
            inp.control_interface = ruckig.ControlInterface.Position
            inp.target_position = target.tolist()
            inp.target_velocity = inp.target_acceleration = [0.0] * self.n
            inp.synchronization = ruckig.Synchronization.Time
        self._otg.delta_time = dt
        try:
            result = self._otg.update(inp, out)
        except ruckig.RuckigError:   # a state Ruckig cannot start from: the command is held where it is
            self.reset(self.position)
            return self.position.copy()
        self.position = np.array(out.new_position)
        self.velocity = np.array(out.new_velocity)
        self.acceleration = np.array(out.new_acceleration)
        if result == ruckig.Result.Finished and not streaming:
            if np.abs(self.position - target).max() <= ARRIVED:
                self.position = target.copy()   # arrived: exactly at the command (not a rounding off it)
            else:
                self._otg.reset()   # Ruckig would hold its profile's end: plan the rest from here
        return self.position.copy()


def _within(wanted: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``wanted`` scaled as a whole (its direction kept: the legs' velocities keep their ratios, the
    pose its path) until every leg is within [``low``, ``high``], then clipped (a bound on the
    wrong side of zero: that leg must brake first)."""
    over = np.where(wanted > high, high / np.where(wanted > high, wanted, 1.0),
                    np.where(wanted < low, low / np.where(wanted < low, wanted, -1.0), 1.0))
    return np.clip(wanted * np.clip(over.min(), 0.0, 1.0), low, high)


def stream_setpoints(commands, period: float, limits: ActuatorLimits, *, settle: float = 0.0) -> np.ndarray:
    """The driver's setpoints (m, n) every :data:`DRIVER_PERIOD` for ``commands`` (k, n) arriving
    every ``period`` [s] from rest at the first, and ``settle`` [s] after the last."""
    commands = np.asarray(commands, dtype=float)
    gen = JerkLimitedSetpoints(limits, commands[0])
    steps = int(round((period * (len(commands) - 1) + settle) / DRIVER_PERIOD))
    per_command = max(1, int(round(period / DRIVER_PERIOD)))
    out = np.empty((steps + 1, commands.shape[1]))
    out[0] = commands[0]
    for k in range(1, steps + 1):
        i = (k - 1) // per_command
        if (k - 1) % per_command == 0 and i < len(commands):
            gen.command(commands[i], (k - 1) * DRIVER_PERIOD)
        out[k] = gen.step((k - 1) * DRIVER_PERIOD, DRIVER_PERIOD)
    return out
