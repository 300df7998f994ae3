"""Robot description of an RRPS parallel climbing robot, and its YAML format.

Two rings joined by six legs. Leg i has its universal joint on ring_a at ``ring_a_anchors[i]``
(ring_a frame) and its spherical joint on ring_b at ``ring_b_anchors[i]`` (ring_b frame).
All kinematics is written for ``a_T_b``, the pose of ring_b in ring_a's frame (docs/robot-model.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property, wraps
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Mapping, TypeVar

import numpy as np

from rrps_description.bus import BusConfig
from rrps_description.loads import GripperCapacity, Payload, ToolWrench, check_payload
from rrps_description.motion_limits import (
    GripperTime,
    MotionLimits,
    check_rate_limits,
    motion_limits,
)
from rrps_description.robot_parts import (
    ExtraRingDof,
    LinkInertia,
    RigidBodyInertia,
    RobotDescriptionError,
    Tool,
    as_array,
    as_scalar,
    check_inertia,
    check_tool,
    combine_bodies,
)
from rrps_description.robot_yaml import GRAVITY_MIGRATION, geometry_arguments, read_description
from rrps_description.rotations import normalize_quat, quat_xyzw_to_matrix

__all__ = [
    'RobotDescriptionError',
    'RigidBodyInertia',
    'Tool',
    'combine_bodies',
    'LinkInertia',
    'ExtraRingDof',
    'RobotGeometry',
    'GRAVITY_MIGRATION',
    'shipped_robots',
    'robot_path',
    'load_robot',
    'per_geometry',
]

_T = TypeVar('_T')

GRIPPER_KINDS = ('clamp', 'hook', 'suction', 'none')

@dataclass(frozen=True, kw_only=True)
class RobotGeometry:
    """Geometry, limits and inertias of one RRPS robot (SI units); only the anchors are required.

    ``ring_a_body``/``ring_b_body``: each ring with what it carries (tool, payload) as one rigid body,
    as the dynamics and statics use it. Gravity is the world's (:mod:`.world`). Defaults: the joints'
    neutral axes along the legs at home; home is ring_b parallel to ring_a, legs mid-stroke."""

    ring_a_anchors: np.ndarray
    ring_b_anchors: np.ndarray
    name: str = 'custom'
    min_length: float = 0.0
    max_length: float = math.inf
    max_speed: float = math.inf
    max_acceleration: float = math.inf
    max_jerk: float = math.inf
    max_force: float = math.inf
    leg_radius: float = 0.0
    universal_max_angle: float = math.pi
    spherical_max_angle: float = math.pi
    min_conditioning: float = 0.0
    ring_a_joint_axes: np.ndarray | None = None
    ring_b_joint_axes: np.ndarray | None = None
    ring_a_inertia: RigidBodyInertia = field(default_factory=RigidBodyInertia)
    ring_b_inertia: RigidBodyInertia = field(default_factory=RigidBodyInertia)
    lower_link: LinkInertia = field(default_factory=LinkInertia)
    upper_link: LinkInertia = field(default_factory=LinkInertia)
    home_position: np.ndarray | None = None
    home_quaternion_xyzw: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))
    grippers: Mapping[str, str] = field(default_factory=lambda: {'ring_a': 'clamp', 'ring_b': 'clamp'})
    extra_dof: Mapping[str, ExtraRingDof] = field(default_factory=dict)
    #: each ring's gripper open/close times (:mod:`rrps_description.motion_limits`; not given: the default)
    gripper_time: Mapping[str, GripperTime] = field(default_factory=dict)
    tool: Tool | None = None
    payload: Payload | None = None
    tool_wrench: ToolWrench | None = None
    holding: Mapping[str, GripperCapacity] = field(default_factory=dict)
    description: str = ''
    #: the fieldbus of the robot's drives (the YAML's optional ``bus`` section, :mod:`rrps_description.bus`)
    bus: BusConfig | None = None

    def __post_init__(self) -> None:
        A = as_array(self.ring_a_anchors, (6, 3), 'ring_a.anchors')
        B = as_array(self.ring_b_anchors, (6, 3), 'ring_b.anchors')
        object.__setattr__(self, 'ring_a_anchors', A)
        object.__setattr__(self, 'ring_b_anchors', B)
        self._check_legs()
        self._check_inertias()
        if self.tool is not None:
            check_tool(self.tool)
        self._check_loads()
        self._set_home()
        self._set_joint_axes()
        self._check_grippers()
        self._check_extra_dof()

    def _check_legs(self) -> None:
        lo = as_scalar(self.min_length, 'legs.min_length', nonnegative=True)
        hi = self.max_length if self.max_length == math.inf else as_scalar(
            self.max_length, 'legs.max_length', positive=True)
        if lo >= hi:
            raise RobotDescriptionError(
                f'legs.min_length ({lo}) must be < legs.max_length ({hi})')
        check_rate_limits({key: getattr(self, key) for key in ('max_speed', 'max_acceleration', 'max_jerk',
                                                               'max_force')})
        as_scalar(self.leg_radius, 'legs.radius', nonnegative=True)
        for key in ('universal_max_angle', 'spherical_max_angle'):
            value = as_scalar(getattr(self, key), f'legs.{key}', positive=True)
            if value > math.pi:
                raise RobotDescriptionError(f'legs.{key}: must be <= pi, got {value}')
        c = as_scalar(self.min_conditioning, 'limits.min_conditioning', nonnegative=True)
        if c >= 1.0:
            raise RobotDescriptionError('limits.min_conditioning: must be < 1')

    def _check_inertias(self) -> None:
        for key, body in (('ring_a', self.ring_a_inertia), ('ring_b', self.ring_b_inertia)):
            as_scalar(body.mass, f'{key}.mass', positive=True)
            object.__setattr__(body, 'com', as_array(body.com, (3,), f'{key}.com'))
            object.__setattr__(body, 'inertia', as_array(body.inertia, (3, 3), f'{key}.inertia'))
            check_inertia(body.inertia, f'{key}.inertia')
        for key, link in (('legs.lower', self.lower_link), ('legs.upper', self.upper_link)):
            as_scalar(link.mass, f'{key}.mass', positive=True)
            as_scalar(link.com_from_joint, f'{key}.com_from_joint', nonnegative=True)
            as_scalar(link.inertia_transverse, f'{key}.inertia_transverse', positive=True)
            as_scalar(link.inertia_axial, f'{key}.inertia_axial', positive=True)
            if link.inertia_axial > 2.0 * link.inertia_transverse:
                raise RobotDescriptionError(
                    f'{key}.inertia_axial: must be <= 2 * inertia_transverse (triangle inequality)')

    def _set_home(self) -> None:
        q = as_array(self.home_quaternion_xyzw, (4,), 'home.quaternion')
        if abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise RobotDescriptionError('home.quaternion: must be a unit quaternion (x, y, z, w)')
        q = normalize_quat(q)
        q.setflags(write=False)
        object.__setattr__(self, 'home_quaternion_xyzw', q)
        if self.home_position is None:
            object.__setattr__(self, 'home_position', self._default_home_position())
        else:
            object.__setattr__(self, 'home_position',
                               as_array(self.home_position, (3,), 'home.position'))

    def _set_joint_axes(self) -> None:
        """Universal (ring_a) and spherical (ring_b) joint axes: given, or along the home legs."""
        home_legs = self._home_leg_vectors()
        if np.any(np.linalg.norm(home_legs, axis=1) < 1e-9):
            raise RobotDescriptionError('home: a leg has zero length at the home pose')
        for key, attr, frame_legs in (
                ('ring_a.joint_axes', 'ring_a_joint_axes', home_legs),
                ('ring_b.joint_axes', 'ring_b_joint_axes',
                 -(home_legs @ quat_xyzw_to_matrix(self.home_quaternion_xyzw)))):
            axes = getattr(self, attr)
            axes = frame_legs if axes is None else as_array(axes, (6, 3), key)
            norms = np.linalg.norm(axes, axis=1)
            if np.any(norms < 1e-9):
                raise RobotDescriptionError(f'{key}: axes must be non-zero')
            axes = axes / norms[:, None]
            axes.setflags(write=False)
            object.__setattr__(self, attr, axes)

    def _check_grippers(self) -> None:
        grippers = dict(self.grippers)
        for ring in ('ring_a', 'ring_b'):
            kind = grippers.get(ring, 'clamp')
            if kind not in GRIPPER_KINDS:
                raise RobotDescriptionError(f'{ring}.gripper: must be one of {GRIPPER_KINDS}, got {kind!r}')
            grippers[ring] = kind
        object.__setattr__(self, 'grippers', grippers)

    def _check_extra_dof(self) -> None:
        for ring, dof in self.extra_dof.items():
            if ring not in ('ring_a', 'ring_b'):
                raise RobotDescriptionError(f'extra_dof.{ring}: only ring_a and ring_b have one')
            axis = as_array(dof.axis, (3,), f'extra_dof.{ring}.axis')
            if np.linalg.norm(axis) < 1e-9:
                raise RobotDescriptionError(f'extra_dof.{ring}.axis: must be non-zero')
            object.__setattr__(dof, 'axis', axis / np.linalg.norm(axis))
            lo_ = as_scalar(dof.min_angle, f'extra_dof.{ring}.min_angle')
            hi_ = as_scalar(dof.max_angle, f'extra_dof.{ring}.max_angle')
            if lo_ >= hi_:
                raise RobotDescriptionError(f'extra_dof.{ring}: min_angle must be < max_angle')

    def _check_loads(self) -> None:
        if self.payload is not None:
            object.__setattr__(self, 'payload', check_payload(self.payload))
        if self.tool_wrench is not None and self.tool is None:
            raise RobotDescriptionError('tool_wrench: acts at the tool-centre point, but there is no tool section')
        for ring in self.holding:
            if ring not in ('ring_a', 'ring_b'):
                raise RobotDescriptionError(f'{ring}.holding: only ring_a and ring_b have grippers')

    # --- derived quantities -------------------------------------------------------------

    def _home_leg_vectors(self) -> np.ndarray:
        R = quat_xyzw_to_matrix(self.home_quaternion_xyzw)
        return self.home_position + self.ring_b_anchors @ R.T - self.ring_a_anchors

    def _default_home_position(self) -> np.ndarray:
        planar = self.ring_b_anchors[:, :2] - self.ring_a_anchors[:, :2]
        dz = self.ring_b_anchors[:, 2] - self.ring_a_anchors[:, 2]
        horizontal = np.linalg.norm(planar, axis=1)
        if math.isfinite(self.max_length):
            target = 0.5 * (self.min_length + self.max_length)
            h = float(np.mean(np.sqrt(np.maximum(target**2 - horizontal**2, 1e-6)) - dz))
        else:
            h = float(max(np.max(np.linalg.norm(self.ring_a_anchors, axis=1)), 1e-3))
        return np.array([0.0, 0.0, h])

    def _with_payload(self, body: RigidBodyInertia, ring: str) -> RigidBodyInertia:
        p = self.payload
        if p is None or p.ring != ring or p.mass == 0.0:
            return body
        return combine_bodies(body, RigidBodyInertia(mass=p.mass, com=p.com, inertia=p.inertia),
                              np.eye(3), np.zeros(3))

    @cached_property
    def ring_a_body(self) -> RigidBodyInertia:
        """ring_a as one rigid body in its frame: the ring and a payload it carries."""
        return self._with_payload(self.ring_a_inertia, 'ring_a')

    @cached_property
    def ring_b_body(self) -> RigidBodyInertia:
        """ring_b as one rigid body in its frame: the ring, its tool and a payload it carries."""
        body = self.ring_b_inertia
        if self.tool is not None:
            t = self.tool
            body = combine_bodies(body, RigidBodyInertia(mass=t.mass, com=t.com, inertia=t.inertia),
                                  quat_xyzw_to_matrix(t.quaternion_xyzw), t.position)
        return self._with_payload(body, 'ring_b')

    @cached_property
    def motion_limits(self) -> MotionLimits:
        """The legs' speed, acceleration and jerk limits and the grippers' times, defaults filled in
        (:func:`rrps_description.motion_limits.motion_limits`: RobotDescriptionError without max_speed)."""
        return motion_limits(self)

    @property
    def total_mass(self) -> float:
        """Both rings, what they carry and the twelve leg links [kg]."""
        return (self.ring_a_body.mass + self.ring_b_body.mass
                + 6.0 * (self.lower_link.mass + self.upper_link.mass))

    @property
    def home_lengths(self) -> np.ndarray:
        """Leg lengths at the home pose [m]."""
        return np.linalg.norm(self._home_leg_vectors(), axis=1)

    @cached_property
    def characteristic_length(self) -> float:
        """Mean anchor radius of the two rings [m]: the length that makes Jacobians unit-consistent."""
        r = np.concatenate([np.linalg.norm(self.ring_a_anchors, axis=1),
                            np.linalg.norm(self.ring_b_anchors, axis=1)])
        return float(max(np.mean(r), 1e-6))

    def with_(self, **changes: Any) -> 'RobotGeometry':
        """A copy with some fields changed (re-validated)."""
        return replace(self, **changes)

    # --- YAML -----------------------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = '<dict>') -> 'RobotGeometry':
        """Build from the parsed YAML schema (:mod:`rrps_description.robot_yaml`); errors name the file and the key."""
        try:
            return cls(**geometry_arguments(data, source))
        except RobotDescriptionError as exc:
            raise RobotDescriptionError(f'{source}: {exc}') from None

    @classmethod
    def from_yaml(cls, path: str | Path) -> 'RobotGeometry':
        """Load a robot description file (see ``robots/*.yaml`` for the schema)."""
        path = Path(path)
        data = read_description(path)
        return cls.from_dict(data, source=str(path))




def shipped_robots() -> list[str]:
    """Names of the robot descriptions shipped with rrps_description."""
    folder = resources.files('rrps_description') / 'robots'
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith('.yaml'))


def robot_path(name_or_path: str | Path) -> Path:
    """Path of a shipped robot (by name, e.g. ``pole_climber``) or of a YAML file."""
    text = str(name_or_path)
    if text.endswith(('.yaml', '.yml')) or '/' in text:
        return Path(text)
    path = Path(str(resources.files('rrps_description') / 'robots' / f'{text}.yaml'))
    if not path.exists():
        raise RobotDescriptionError(
            f'unknown robot {text!r}: not a YAML path and not one of {shipped_robots()}')
    return path


def load_robot(name_or_path: str | Path) -> RobotGeometry:
    """Load a shipped robot by name or a robot description file by path."""
    return RobotGeometry.from_yaml(robot_path(name_or_path))


def per_geometry(compute: Callable[[RobotGeometry], _T]) -> Callable[[RobotGeometry], _T]:
    """``compute(geometry)`` computed once per geometry object (a geometry is immutable): for the
    constants derived from it, which callers must not change."""
    cache: dict[int, tuple[RobotGeometry, _T]] = {}

    @wraps(compute)
    def cached(geometry: RobotGeometry) -> _T:
        entry = cache.get(id(geometry))
        if entry is not None and entry[0] is geometry:
            return entry[1]
        value = compute(geometry)
        if len(cache) >= 16:
            cache.clear()
        cache[id(geometry)] = (geometry, value)
        return value
    return cached
