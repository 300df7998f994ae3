"""Teleoperation parameters: mapping modes and the guards' limits (SI units), validated.

:class:`TeleopConfig` is what :class:`rrps_teleop.mapping.TeleopMapping` runs with and what the
teleop node's parameters set; an invalid value raises ValueError naming the parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rrps_description.tool import TARGET_FRAMES

__all__ = ['MODES', 'ROTATION_MODES', 'TeleopConfig', 'validate_scale']

MODES = ('cartesian', 'joint')
ROTATION_MODES = ('relative', 'absolute')


def validate_scale(value, name: str = 'translation_scale') -> float:
    """A scale factor as float; ValueError unless it is finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a number, got {value!r}') from None
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f'{name} must be finite and > 0, got {value!r}')
    return v


@dataclass(frozen=True)
class TeleopConfig:
    """Mapping and guard parameters (SI units); validated on construction (ValueError)."""

    mode: str = 'cartesian'
    translation_scale: float = 4.0
    rotation_mode: str = 'relative'
    #: a_i of the joint-space map, one per leg (a scalar is broadcast).
    joint_scale: tuple = (4.0,) * 6
    enable_timeout: float = 0.2
    master_timeout: float = 0.1
    max_linear_speed: float = 0.05
    max_angular_speed: float = 0.25
    #: inverse condition number below which steps towards the singularity slow down.
    singularity_slowdown: float = 0.08
    #: inverse condition number where motion towards the singularity halts (None: the robot's min_conditioning).
    singularity_halt: float | None = None
    #: leg-leg interference margin [m] below which steps towards interference slow down.
    collision_slowdown: float = 0.02
    #: absolute rotation mode engages only if master and slave orientations differ less [rad].
    align_tolerance: float = 0.1
    #: longest time step [s] the speed limits allow (a late step never gets a large jump).
    max_period: float = 0.05
    #: hold when the slave's pose (its measured state) is older than this [s].
    state_timeout: float = 0.2
    #: the operator's round trip [s] above which the speeds are scaled down (to 1/4 at hold_latency).
    slow_latency: float = 0.2
    #: the operator's round trip [s] above which the robot holds.
    hold_latency: float = 0.3
    #: the frame the master moves in Cartesian mode: ring_b's origin or the tool-centre point
    #: (``tool``: translations move the tool tip, rotations turn about it).
    control_frame: str = 'ring_b'

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f'mode must be one of {MODES}, got {self.mode!r}')
        if self.control_frame not in TARGET_FRAMES:
            raise ValueError(f'control_frame must be one of {TARGET_FRAMES}, got {self.control_frame!r}')
        if self.rotation_mode not in ROTATION_MODES:
            raise ValueError(f'rotation_mode must be one of {ROTATION_MODES}, got {self.rotation_mode!r}')
        object.__setattr__(self, 'translation_scale', validate_scale(self.translation_scale))
        a = np.broadcast_to(np.asarray(self.joint_scale, dtype=float), (6,)) if np.ndim(self.joint_scale) == 0 \
            else np.asarray(self.joint_scale, dtype=float)
        if a.shape != (6,):
            raise ValueError(f'joint_scale must be a scalar or 6 values, got shape {a.shape}')
        object.__setattr__(self, 'joint_scale', tuple(validate_scale(v, 'joint_scale') for v in a))
        for name in ('enable_timeout', 'master_timeout', 'max_linear_speed', 'max_angular_speed',
                     'singularity_slowdown', 'collision_slowdown', 'align_tolerance', 'max_period',
                     'state_timeout', 'slow_latency', 'hold_latency'):
            validate_scale(getattr(self, name), name)
        if not self.slow_latency < self.hold_latency:
            raise ValueError(f'slow_latency must be < hold_latency, got {self.slow_latency!r}, '
                             f'{self.hold_latency!r}')
        if self.singularity_halt is not None:
            h = float(self.singularity_halt)
            if not (math.isfinite(h) and 0.0 <= h < self.singularity_slowdown):
                raise ValueError('singularity_halt must be in [0, singularity_slowdown), '
                                 f'got {self.singularity_halt!r}')

    def with_(self, **changes) -> 'TeleopConfig':
        """A validated copy with some fields changed."""
        return replace(self, **changes)
