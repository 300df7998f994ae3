"""How fast a robot may move: each leg's speed, acceleration and jerk, and how long each gripper
takes to open and close (the YAML keys: docs/robot-model.md, 'The robot YAML').

Keys left out get conservative defaults (``max_acceleration = max_speed /`` :data:`DEFAULT_RAMP_TIME`,
``max_jerk = max_acceleration /`` :data:`DEFAULT_JERK_TIME`, :data:`DEFAULT_GRIPPER_TIME`); without
``legs.max_speed`` :func:`motion_limits` refuses. Every reader names the offending key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from rrps_description.names import RINGS
from rrps_description.robot_parts import RobotDescriptionError, as_scalar

__all__ = ['DEFAULT_RAMP_TIME', 'DEFAULT_JERK_TIME', 'DEFAULT_GRIPPER_TIME', 'STREAM_SPEED_SHARE',
           'STREAM_RATE_SHARE', 'GripperTime', 'ActuatorLimits', 'MotionLimits', 'motion_limits',
           'motion_limits_from', 'stream_limits', 'check_rate_limits']

#: The legs reach full speed in this time when the description gives no acceleration [s].
DEFAULT_RAMP_TIME = 0.5
#: The legs reach full acceleration in this time when the description gives no jerk [s].
DEFAULT_JERK_TIME = 0.2
#: A gripper opens or closes in this time when the description gives none [s].
DEFAULT_GRIPPER_TIME = 2.0
#: The share of the legs' speed limit a stream of commands to the driver uses (a climbing plan,
#: teleop's targets).
STREAM_SPEED_SHARE = 0.97
#: The share of the legs' acceleration and jerk limits such a stream uses. The driver's setpoints
#: (``rrps_hardware.setpoints``) follow a stream one command period behind and need the rest to
#: keep up with its acceleration and braking: the pole climber's planned motions, streamed at
#: 50 Hz, ended 0.32 mm of leg length past their last command at 97 % of these limits, and
#: 0.08 mm at 85 % (docs/measurements.md, "Headroom for the driver's setpoints").
STREAM_RATE_SHARE = 0.85


@dataclass(frozen=True)
class GripperTime:
    """How long a gripper takes to open and to close [s]."""

    open: float = DEFAULT_GRIPPER_TIME
    close: float = DEFAULT_GRIPPER_TIME

    def switch(self, close: bool) -> float:
        """The time [s] of one switch: closing (``close``) or opening."""
        return self.close if close else self.open


@dataclass(frozen=True)
class ActuatorLimits:
    """One actuator's limits: ``speed`` [m/s], ``acceleration`` [m/s²], ``jerk`` [m/s³]."""

    speed: float
    acceleration: float
    jerk: float


@dataclass(frozen=True)
class MotionLimits:
    """A robot's limits in time: its legs' (:class:`ActuatorLimits`) and each ring's gripper
    times (:class:`GripperTime`)."""

    legs: ActuatorLimits
    grippers: Mapping[str, GripperTime]


def stream_limits(full: ActuatorLimits) -> ActuatorLimits:
    """The limits a command stream is timed within: :data:`STREAM_SPEED_SHARE` of ``full``'s
    speed, :data:`STREAM_RATE_SHARE` of its acceleration and jerk."""
    return ActuatorLimits(STREAM_SPEED_SHARE * full.speed, STREAM_RATE_SHARE * full.acceleration,
                          STREAM_RATE_SHARE * full.jerk)


def check_rate_limits(values: Mapping[str, float]) -> None:
    """RobotDescriptionError naming the key unless each ``legs.<key>`` rate limit given
    (max_speed, max_acceleration, max_jerk; infinite: not given) is finite and > 0."""
    for key, value in values.items():
        if value != math.inf:
            as_scalar(value, f'legs.{key}', positive=True)


def motion_limits(geometry) -> MotionLimits:
    """The :class:`MotionLimits` of a :class:`~rrps_description.geometry.RobotGeometry`, the
    documented defaults filled in (module docstring); RobotDescriptionError without a finite
    ``legs.max_speed``."""
    speed = geometry.max_speed
    if not math.isfinite(speed):
        raise RobotDescriptionError(f'{geometry.name}: legs.max_speed: not given; a timed motion needs the '
                                    "legs' speed limit [m/s]")
    acceleration = geometry.max_acceleration
    if not math.isfinite(acceleration):
        acceleration = speed / DEFAULT_RAMP_TIME
    jerk = geometry.max_jerk
    if not math.isfinite(jerk):
        jerk = acceleration / DEFAULT_JERK_TIME
    grippers = {ring: geometry.gripper_time.get(ring, GripperTime()) for ring in RINGS}
    return MotionLimits(ActuatorLimits(float(speed), float(acceleration), float(jerk)), grippers)


def _gripper_time(sec: Any, ring: str) -> GripperTime:
    if not isinstance(sec, Mapping):
        raise RobotDescriptionError(f'{ring}.gripper_time: expected a mapping {{open: S, close: S}}')
    unknown = set(sec) - {'open', 'close'}
    if unknown:
        raise RobotDescriptionError(f'{ring}.gripper_time: unknown keys {sorted(unknown)} (open, close)')
    return GripperTime(**{key: as_scalar(sec.get(key, DEFAULT_GRIPPER_TIME), f'{ring}.gripper_time.{key}',
                                         positive=True) for key in ('open', 'close')})


def motion_limits_from(legs: Mapping[str, Any], ring_a: Mapping[str, Any],
                       ring_b: Mapping[str, Any]) -> dict[str, Any]:
    """RobotGeometry keyword arguments of the YAML's ``legs.max_acceleration``,
    ``legs.max_jerk`` and the rings' ``gripper_time`` that are given."""
    kwargs: dict[str, Any] = {key: as_scalar(legs[key], f'legs.{key}', positive=True)
                              for key in ('max_acceleration', 'max_jerk') if key in legs}
    kwargs['gripper_time'] = {ring: _gripper_time(sec['gripper_time'], ring)
                              for ring, sec in (('ring_a', ring_a), ('ring_b', ring_b)) if 'gripper_time' in sec}
    return kwargs
