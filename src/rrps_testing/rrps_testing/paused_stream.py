"""One leg's stream of targets from a climb paused mid-motion, braked along its path as the climb
does (rrps_climbing.path_brake) or stopped at once: what the brake's unit tests feed the driver's
setpoints and what the multi-host tests' settle bound (rrps_testing.multihost_stack.brake_settle)
is computed from."""

from __future__ import annotations

import numpy as np

from rrps_climbing.path_brake import PathBrake
from rrps_climbing.phase_path import PlayClock
from rrps_description.motion_limits import ActuatorLimits, stream_limits

__all__ = ['paused_stream']


def paused_stream(limits: ActuatorLimits, period: float, *, braked: bool = True) -> np.ndarray:
    """One leg's commands (k, 1) [m] every ``period`` [s] of a climb paused mid-motion: from rest
    up to the stream speed of ``limits`` at its stream acceleration, on at that speed, then braked
    along the path as the climb does (rrps_climbing.path_brake), or (``braked`` False) stopped at once."""
    stream = stream_limits(limits)
    ramp = np.minimum(stream.speed, stream.acceleration * period * np.arange(1, 100))
    commands = list(np.cumsum(ramp * period))
    if braked:
        clock = PlayClock(period)
        clock.advance(0.0)
        clock.brake(PathBrake(stream))
        at, start, now = commands[-1], clock.t, 0.0
        while clock.braking:
            now += period
            commands.append(at + stream.speed * (clock.advance(now) - start))
    return np.asarray(commands)[:, None]
