"""Teleoperation parameters: teleop_node's schema (:data:`PARAMETERS`) and :class:`TeleopConfig`,
the mapping's configuration from :data:`CONFIG_PARAMETERS` (SI units), whose invalid values raise
ValueError naming the parameter."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rrps_description.names import RING_A_FRAME, RINGS
from rrps_description.tool import TARGET_FRAMES
from rrps_description.world import IDENTITY_QUATERNION
from rrps_interfaces.link import SOURCES
from rrps_interfaces.teleop import MASTER_FRAME
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.scheduling import scheduling_parameters
from rrps_runtime.supervision import OPERATOR_RT_PRIORITY

__all__ = ['CONFIG_PARAMETERS', 'CONTROL_TRIGGERS', 'MODES', 'PARAMETERS', 'ROTATION_MODES', 'TeleopConfig',
           'validate_scale']

MODES = ('cartesian', 'joint')
ROTATION_MODES = ('relative', 'absolute')
#: when the teleop node runs a control step: on each master sample or on a timer.
CONTROL_TRIGGERS = ('message', 'timer')

#: teleop_node's parameters that are the fields of :class:`TeleopConfig` (settable at run time;
#: validated by TeleopConfig, and any change is a clutch).
CONFIG_PARAMETERS = (
    Parameter('mode', 'cartesian', 'map master poses (cartesian) or leg lengths (joint)', choices=MODES,
              dynamic=True),
    Parameter('translation_scale', 4.0, 'slave translation = scale x master translation since engage',
              range=(1e-3, 1e3), dynamic=True),
    Parameter('rotation_mode', 'relative', 'master rotation since engage (relative) or its orientation '
              '(absolute)', choices=ROTATION_MODES, dynamic=True),
    Parameter('control_frame', 'ring_b', "the frame the master moves in cartesian mode: ring_b's origin or "
              'the tool-centre point (translations move the tool tip, rotations turn about it)',
              choices=TARGET_FRAMES, dynamic=True),
    Parameter('joint_scale', (4.0,) * 6, 'joint mode: a_i of L_slave,i = a_i L_master,i + b_i (6 values > 0; '
              'b_i set at engage)', dynamic=True),
    Parameter('enable_timeout', 0.2, 'hold when teleop/enable was not true for this long', unit='s',
              range=(0.01, 5.0), dynamic=True),
    Parameter('master_timeout', 0.1, 'hold when the master data is older than this', unit='s',
              range=(0.005, 5.0), dynamic=True),
    Parameter('max_linear_speed', 0.05, 'slave translation speed limit', unit='m/s', range=(1e-4, 10.0),
              dynamic=True),
    Parameter('max_angular_speed', 0.25, 'slave rotation speed limit', unit='rad/s', range=(1e-4, 100.0),
              dynamic=True),
    Parameter('singularity_slowdown', 0.08, 'inverse condition number below which motion towards a '
              'singularity slows down', range=(1e-4, 1.0), dynamic=True),
    Parameter('singularity_halt', None, 'inverse condition number where motion towards a singularity halts',
              range=(0.0, 1.0), dynamic=True, type=float, unset_note="the robot's min_conditioning"),
    Parameter('collision_slowdown', 0.02, 'leg-leg interference margin below which motion towards it slows '
              'down', unit='m', range=(1e-5, 1.0), dynamic=True),
    Parameter('align_tolerance', 0.1, 'absolute rotation mode: largest master/slave orientation difference '
              'to engage', unit='rad', range=(1e-4, math.pi), dynamic=True),
    Parameter('state_timeout', 0.2, 'hold when the slave pose (its measured state) is older than this',
              unit='s', range=(0.01, 5.0), dynamic=True),
    Parameter('slow_latency', 0.2, "the operator's round trip above which speeds are scaled down (to 1/4 at "
              'hold_latency)', unit='s', range=(0.001, 5.0), dynamic=True),
    Parameter('hold_latency', 0.3, "the operator's round trip above which the robot holds", unit='s',
              range=(0.001, 5.0), dynamic=True),
    Parameter('load_guards', True, 'slow down near and halt at the actuator force limit and a holding margin of '
              "zero (the statics of the robot at rest on its supporting ring, with its payload)", dynamic=True),
    Parameter('force_slowdown', 0.1, 'force margin 1 - max|f_i| / max_force below which motion towards the limit '
              'slows down', range=(1e-4, 1.0), dynamic=True),
    Parameter('holding_slowdown', 0.1, "holding margin (1 - the supporting gripper's utilisation) below which "
              'motion towards zero slows down', range=(1e-4, 1.0), dynamic=True),
)

#: teleop_node's parameters (descriptors, the shipped file, the docs' table and the defaults of
#: TeleopConfig and of the fixture's stiffness come from here).
PARAMETERS = NodeParameters('teleop_node', 'rrps_teleop', [
    ROBOT,
    Parameter('frame_id', RING_A_FRAME, 'frame of pose and target_pose'),
    Parameter('master_frame_id', MASTER_FRAME, 'frame of master/pose'),
    Parameter('robot_topics', 'direct', "read the robot's state from its own topics (direct) or from its "
              'link relay (link: link/pose, link/diagnostics; docs/deployment.md, field links)', choices=SOURCES),
    Parameter('robot_namespace', '', "namespace of the driven robot's topics (pose, target_pose, "
              "teleop/status, ...; empty: this node's own); a change switches robots: the clutch is "
              'released and the deadman must be released and pressed again', dynamic=True),
    Parameter('control', 'message', 'run the control step on each master sample or on a timer',
              choices=CONTROL_TRIGGERS),
    Parameter('control_rate', 200.0, 'control rate in timer mode', unit='Hz', range=(1.0, 2000.0)),
    Parameter('jerk_limited', True, "stream the targets jerk-limited within the legs' speed, acceleration and "
              'jerk limits, stopping with the fastest jerk-limited stop (rrps_teleop.target_stream); false: each '
              'guarded command as it is'),
    Parameter('status_rate', 10.0, 'teleop/status rate when unchanged', unit='Hz', range=(0.1, 100.0)),
    Parameter('feedback_rate', 20.0, 'master/feedback (the virtual fixture) rate', unit='Hz',
              range=(1.0, 200.0)),
    Parameter('feedback_scale', 1.0, 'master force per newton of the fixture on the slave', range=(0.0, 100.0)),
    Parameter('fixture_stiffness', 10.0, 'the fixture push of one limit at the limit', unit='N',
              range=(1e-3, 1e4)),
    *CONFIG_PARAMETERS,
    Parameter('support', 'ring_a', 'the ring gripping the structure while teleoperated (the support of the '
              'load guards)', choices=RINGS),
    Parameter('world_q_support', IDENTITY_QUATERNION, "the supporting ring's attitude in the world "
              '(x, y, z, w; gravity is (0, 0, -9.81) m/s^2 there)'),
    Parameter('payload_mass', None, 'a point-mass payload for the load guards', unit='kg', range=(0.0, 1e5),
              type=float, unset_note="the robot's payload (none unless its YAML gives one)"),
    Parameter('payload_com', (0.0, 0.0, 0.0), "the payload's centre of mass in its ring's frame", unit='m'),
    Parameter('payload_ring', 'ring_b', 'the ring carrying the payload', choices=RINGS),
    *scheduling_parameters(OPERATOR_RT_PRIORITY),
])


def validate_scale(value, name: str = 'translation_scale') -> float:
    """A scale factor as float; ValueError unless it is finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a number, got {value!r}') from None
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f'{name} must be finite and > 0, got {value!r}')
    return v


def _schema_fields(parameters):
    """A class decorator: one annotated field per parameter, its default the schema's (before
    :func:`dataclasses.dataclass` makes them the dataclass's fields)."""
    def add(cls):
        for p in parameters:
            cls.__annotations__[p.name] = p.type if p.default is not None else p.type | None
            setattr(cls, p.name, p.default)
        return cls
    return add


#: the float parameters whose range says they are positive: each validated finite and > 0.
_POSITIVE = tuple(p.name for p in CONFIG_PARAMETERS if p.type is float and p.range and p.range[0] > 0.0)


@dataclass(frozen=True, kw_only=True)
@_schema_fields(CONFIG_PARAMETERS)
class TeleopConfig:
    """Mapping and guard parameters (SI units): one field per parameter of
    :data:`CONFIG_PARAMETERS`, its default the schema's, and ``max_period``; validated on
    construction (ValueError naming the parameter). ``joint_scale`` is a_i of the joint-space
    map, one per leg (a scalar is broadcast); ``singularity_halt`` None is the robot's
    min_conditioning."""

    #: longest time step [s] the speed limits allow (a late step never gets a large jump).
    max_period: float = 0.05

    def __post_init__(self) -> None:
        for p in CONFIG_PARAMETERS:
            if p.choices and getattr(self, p.name) not in p.choices:
                raise ValueError(f'{p.name} must be one of {p.choices}, got {getattr(self, p.name)!r}')
        for name in (*_POSITIVE, 'max_period'):
            object.__setattr__(self, name, validate_scale(getattr(self, name), name))
        a = np.broadcast_to(np.asarray(self.joint_scale, dtype=float), (6,)) if np.ndim(self.joint_scale) == 0 \
            else np.asarray(self.joint_scale, dtype=float)
        if a.shape != (6,):
            raise ValueError(f'joint_scale must be a scalar or 6 values, got shape {a.shape}')
        object.__setattr__(self, 'joint_scale', tuple(validate_scale(v, 'joint_scale') for v in a))
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
