"""Robot description of an RRPS parallel climbing robot, and its YAML format.

Two rings joined by six legs. Leg i has its universal joint on ring_a at ``ring_a_anchors[i]``
(ring_a frame) and its spherical joint on ring_b at ``ring_b_anchors[i]`` (ring_b frame).
All kinematics is written for ``a_T_b``, the pose of ring_b in ring_a's frame (README: the robot model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from .rotations import normalize_quat, quat_xyzw_to_matrix

__all__ = [
    'RobotDescriptionError',
    'RigidBodyInertia',
    'Tool',
    'combine_bodies',
    'LinkInertia',
    'ExtraRingDof',
    'RobotGeometry',
    'shipped_robots',
    'robot_path',
    'load_robot',
]

GRIPPER_KINDS = ('clamp', 'hook', 'suction', 'none')


class RobotDescriptionError(ValueError):
    """A robot description is malformed; the message names the offending key."""


@dataclass(frozen=True, kw_only=True)
class RigidBodyInertia:
    """Mass [kg], centre of mass [m] and inertia about the com [kg m^2], in the body's frame."""

    mass: float = 1.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.diag([0.05, 0.05, 0.1]))


@dataclass(frozen=True, kw_only=True)
class LinkInertia:
    """One link of a leg, symmetric about the leg axis.

    ``com_from_joint`` is measured from the link's own joint centre along the leg (the lower link
    from the universal joint towards ring_b, the upper link from the spherical joint towards
    ring_a). Inertias are about the com: transverse (about axes normal to the leg) and axial.
    """

    mass: float = 0.2
    com_from_joint: float = 0.05
    inertia_transverse: float = 1e-4
    inertia_axial: float = 1e-5

    def inertia_tensor(self) -> np.ndarray:
        """Body-frame inertia about the com with the leg axis along the link's z."""
        return np.diag([self.inertia_transverse, self.inertia_transverse, self.inertia_axial])


@dataclass(frozen=True, kw_only=True)
class ExtraRingDof:
    """The paper's extra rotational DOF of a ring (section 3.1, Figure 9).

    A revolute joint between the ring and its gripper, about ``axis`` (ring frame, through the
    ring origin), within ``[min_angle, max_angle]`` rad. It turns the whole hexapod about the
    gripped member so that the legs can be re-arranged clear of each other.
    """

    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    min_angle: float = -math.pi
    max_angle: float = math.pi


TOOL_SHAPES = ('cylinder', 'box', 'sphere')


@dataclass(frozen=True, kw_only=True)
class Tool:
    """A tool carried by ring_b (the paper's handler arm for the tool, section 3.2, Figure 10).

    ``position`` [m] and ``quaternion_xyzw``: the tool-centre-point frame in ring_b's frame
    (``b_T_tool``). ``mass`` [kg], ``com`` [m] and ``inertia`` [kg m^2, about the com] in the tool
    frame. ``shape`` (cylinder | box | sphere) and ``size`` [m] (cylinder: radius, length along
    the tool's z ending at the tool centre point; box: x, y, z; sphere: radius) only draw it.
    """

    name: str = 'tool'
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quaternion_xyzw: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))
    mass: float = 1.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.diag([1e-3, 1e-3, 1e-3]))
    shape: str = 'cylinder'
    size: tuple = (0.02, 0.2)

    @property
    def b_T_tool(self) -> np.ndarray:
        """4x4 pose of the tool-centre-point frame in ring_b's frame."""
        T = np.eye(4)
        T[:3, :3] = quat_xyzw_to_matrix(self.quaternion_xyzw)
        T[:3, 3] = self.position
        return T


def combine_bodies(a: RigidBodyInertia, b: RigidBodyInertia, b_R: np.ndarray,
                   b_p: np.ndarray) -> RigidBodyInertia:
    """One rigid body from body ``a`` (in frame F) and body ``b`` whose frame sits at ``b_p``
    with rotation ``b_R`` in F: total mass, mass-weighted com, and the inertia about the new
    com by the parallel-axis theorem, all in F."""
    com_b = b_p + b_R @ b.com
    mass = a.mass + b.mass
    com = (a.mass * a.com + b.mass * com_b) / mass

    def shifted(inertia: np.ndarray, m: float, d: np.ndarray) -> np.ndarray:
        return inertia + m * (float(d @ d) * np.eye(3) - np.outer(d, d))

    inertia = shifted(a.inertia, a.mass, a.com - com) + shifted(b_R @ b.inertia @ b_R.T, b.mass,
                                                              com_b - com)
    return RigidBodyInertia(mass=mass, com=com, inertia=0.5 * (inertia + inertia.T))


def _as_array(value: Any, shape: tuple[int, ...], key: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise RobotDescriptionError(f'{key}: expected numbers of shape {shape}, got {value!r}') from exc
    if arr.shape != shape:
        raise RobotDescriptionError(f'{key}: expected shape {shape}, got {arr.shape}')
    if not np.all(np.isfinite(arr)):
        raise RobotDescriptionError(f'{key}: contains NaN or infinite values')
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


def _as_scalar(value: Any, key: str, *, positive: bool = False, nonnegative: bool = False) -> float:
    if isinstance(value, bool):
        raise RobotDescriptionError(f'{key}: expected a number, got {value!r}')
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise RobotDescriptionError(f'{key}: expected a number, got {value!r}') from exc
    if not math.isfinite(x):
        raise RobotDescriptionError(f'{key}: must be finite, got {value!r}')
    if positive and x <= 0.0:
        raise RobotDescriptionError(f'{key}: must be > 0, got {x}')
    if nonnegative and x < 0.0:
        raise RobotDescriptionError(f'{key}: must be >= 0, got {x}')
    return x


def _check_inertia(inertia: np.ndarray, key: str) -> None:
    if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12):
        raise RobotDescriptionError(f'{key}: inertia must be symmetric')
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] <= 0.0:
        raise RobotDescriptionError(f'{key}: inertia must be positive definite (eigenvalues {eig})')
    if eig[0] + eig[1] < eig[2] * (1.0 - 1e-9):
        raise RobotDescriptionError(f'{key}: principal moments break the triangle inequality {eig}')


@dataclass(frozen=True, kw_only=True)
class RobotGeometry:
    """Geometry, limits and inertias of one RRPS robot (SI units).

    Only the anchors are required: ``RobotGeometry(ring_a_anchors=A, ring_b_anchors=B)``.
    ``ring_b_inertia`` is the ring alone; the dynamics and the statics use ``ring_b_body``, the
    moving platform: the ring and its ``tool`` (if any) as one rigid body.
    Unspecified joint neutral axes are the leg directions at the home pose; an unspecified home
    pose is ring_b parallel to ring_a, raised along ring_a's z so the legs sit mid-stroke (or at
    45 degrees when the stroke is unbounded).
    """

    ring_a_anchors: np.ndarray
    ring_b_anchors: np.ndarray
    name: str = 'custom'
    min_length: float = 0.0
    max_length: float = math.inf
    max_speed: float = math.inf
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
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    home_position: np.ndarray | None = None
    home_quaternion_xyzw: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))
    grippers: Mapping[str, str] = field(default_factory=lambda: {'ring_a': 'clamp', 'ring_b': 'clamp'})
    extra_dof: Mapping[str, ExtraRingDof] = field(default_factory=dict)
    tool: Tool | None = None
    description: str = ''

    def __post_init__(self) -> None:
        A = _as_array(self.ring_a_anchors, (6, 3), 'ring_a.anchors')
        B = _as_array(self.ring_b_anchors, (6, 3), 'ring_b.anchors')
        object.__setattr__(self, 'ring_a_anchors', A)
        object.__setattr__(self, 'ring_b_anchors', B)
        lo = _as_scalar(self.min_length, 'legs.min_length', nonnegative=True)
        hi = self.max_length if self.max_length == math.inf else _as_scalar(
            self.max_length, 'legs.max_length', positive=True)
        if lo >= hi:
            raise RobotDescriptionError(
                f'legs.min_length ({lo}) must be < legs.max_length ({hi})')
        for key in ('max_speed', 'max_force'):
            if getattr(self, key) != math.inf:
                _as_scalar(getattr(self, key), f'legs.{key}', positive=True)
        _as_scalar(self.leg_radius, 'legs.radius', nonnegative=True)
        for key in ('universal_max_angle', 'spherical_max_angle'):
            value = _as_scalar(getattr(self, key), f'legs.{key}', positive=True)
            if value > math.pi:
                raise RobotDescriptionError(f'legs.{key}: must be <= pi, got {value}')
        c = _as_scalar(self.min_conditioning, 'limits.min_conditioning', nonnegative=True)
        if c >= 1.0:
            raise RobotDescriptionError('limits.min_conditioning: must be < 1')
        for key, body in (('ring_a', self.ring_a_inertia), ('ring_b', self.ring_b_inertia)):
            _as_scalar(body.mass, f'{key}.mass', positive=True)
            object.__setattr__(body, 'com', _as_array(body.com, (3,), f'{key}.com'))
            object.__setattr__(body, 'inertia', _as_array(body.inertia, (3, 3), f'{key}.inertia'))
            _check_inertia(body.inertia, f'{key}.inertia')
        for key, link in (('legs.lower', self.lower_link), ('legs.upper', self.upper_link)):
            _as_scalar(link.mass, f'{key}.mass', positive=True)
            _as_scalar(link.com_from_joint, f'{key}.com_from_joint', nonnegative=True)
            _as_scalar(link.inertia_transverse, f'{key}.inertia_transverse', positive=True)
            _as_scalar(link.inertia_axial, f'{key}.inertia_axial', positive=True)
            if link.inertia_axial > 2.0 * link.inertia_transverse:
                raise RobotDescriptionError(
                    f'{key}.inertia_axial: must be <= 2 * inertia_transverse (triangle inequality)')
        if self.tool is not None:
            self._check_tool()
        object.__setattr__(self, 'gravity', _as_array(self.gravity, (3,), 'gravity'))
        q = _as_array(self.home_quaternion_xyzw, (4,), 'home.quaternion')
        if abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise RobotDescriptionError('home.quaternion: must be a unit quaternion (x, y, z, w)')
        q = normalize_quat(q)
        q.setflags(write=False)
        object.__setattr__(self, 'home_quaternion_xyzw', q)
        if self.home_position is None:
            object.__setattr__(self, 'home_position', self._default_home_position())
        else:
            object.__setattr__(self, 'home_position',
                               _as_array(self.home_position, (3,), 'home.position'))
        home_legs = self._home_leg_vectors()
        if np.any(np.linalg.norm(home_legs, axis=1) < 1e-9):
            raise RobotDescriptionError('home: a leg has zero length at the home pose')
        for key, attr, frame_legs in (
                ('ring_a.joint_axes', 'ring_a_joint_axes', home_legs),
                ('ring_b.joint_axes', 'ring_b_joint_axes',
                 -(home_legs @ quat_xyzw_to_matrix(self.home_quaternion_xyzw)))):
            axes = getattr(self, attr)
            axes = frame_legs if axes is None else _as_array(axes, (6, 3), key)
            norms = np.linalg.norm(axes, axis=1)
            if np.any(norms < 1e-9):
                raise RobotDescriptionError(f'{key}: axes must be non-zero')
            axes = axes / norms[:, None]
            axes.setflags(write=False)
            object.__setattr__(self, attr, axes)
        grippers = dict(self.grippers)
        for ring in ('ring_a', 'ring_b'):
            kind = grippers.get(ring, 'clamp')
            if kind not in GRIPPER_KINDS:
                raise RobotDescriptionError(f'{ring}.gripper: must be one of {GRIPPER_KINDS}, got {kind!r}')
            grippers[ring] = kind
        object.__setattr__(self, 'grippers', grippers)
        for ring, dof in self.extra_dof.items():
            if ring not in ('ring_a', 'ring_b'):
                raise RobotDescriptionError(f'extra_dof.{ring}: only ring_a and ring_b have one')
            axis = _as_array(dof.axis, (3,), f'extra_dof.{ring}.axis')
            if np.linalg.norm(axis) < 1e-9:
                raise RobotDescriptionError(f'extra_dof.{ring}.axis: must be non-zero')
            object.__setattr__(dof, 'axis', axis / np.linalg.norm(axis))
            lo_ = _as_scalar(dof.min_angle, f'extra_dof.{ring}.min_angle')
            hi_ = _as_scalar(dof.max_angle, f'extra_dof.{ring}.max_angle')
            if lo_ >= hi_:
                raise RobotDescriptionError(f'extra_dof.{ring}: min_angle must be < max_angle')

    def _check_tool(self) -> None:
        t = self.tool
        object.__setattr__(t, 'position', _as_array(t.position, (3,), 'tool.position'))
        q = _as_array(t.quaternion_xyzw, (4,), 'tool.quaternion')
        if abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise RobotDescriptionError('tool.quaternion: must be a unit quaternion (x, y, z, w)')
        object.__setattr__(t, 'quaternion_xyzw', normalize_quat(q))
        _as_scalar(t.mass, 'tool.mass', positive=True)
        object.__setattr__(t, 'com', _as_array(t.com, (3,), 'tool.com'))
        object.__setattr__(t, 'inertia', _as_array(t.inertia, (3, 3), 'tool.inertia'))
        _check_inertia(t.inertia, 'tool.inertia')
        if t.shape not in TOOL_SHAPES:
            raise RobotDescriptionError(f'tool.shape: must be one of {TOOL_SHAPES}, got {t.shape!r}')
        size = tuple(_as_scalar(v, 'tool.size', positive=True) for v in t.size)
        wanted = {'cylinder': 2, 'box': 3, 'sphere': 1}[t.shape]
        if len(size) != wanted:
            raise RobotDescriptionError(f'tool.size: a {t.shape} takes {wanted} sizes, got {len(size)}')
        object.__setattr__(t, 'size', size)

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

    @cached_property
    def ring_b_body(self) -> RigidBodyInertia:
        """The moving platform as one rigid body in ring_b's frame: the ring and its tool."""
        if self.tool is None:
            return self.ring_b_inertia
        t = self.tool
        return combine_bodies(self.ring_b_inertia,
                              RigidBodyInertia(mass=t.mass, com=t.com, inertia=t.inertia),
                              quat_xyzw_to_matrix(t.quaternion_xyzw), t.position)

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
        """Build from the parsed YAML schema; errors name the file and the key."""
        try:
            return cls._from_dict(data)
        except RobotDescriptionError as exc:
            raise RobotDescriptionError(f'{source}: {exc}') from None

    @classmethod
    def _from_dict(cls, data: Mapping[str, Any]) -> 'RobotGeometry':
        if not isinstance(data, Mapping):
            raise RobotDescriptionError('top level: expected a mapping')
        known = {'name', 'description', 'ring_a', 'ring_b', 'legs', 'gravity', 'home', 'limits',
                 'extra_dof', 'tool'}
        unknown = set(data) - known
        if unknown:
            raise RobotDescriptionError(f'unknown top-level keys {sorted(unknown)}')

        def section(key: str, parent: Mapping[str, Any] = data, prefix: str = '') -> Mapping[str, Any]:
            value = parent.get(key, {})
            if not isinstance(value, Mapping):
                raise RobotDescriptionError(f'{prefix}{key}: expected a mapping')
            return value

        ring_a, ring_b, legs = section('ring_a'), section('ring_b'), section('legs')
        for key, sec in (('ring_a', ring_a), ('ring_b', ring_b)):
            if 'anchors' not in sec:
                raise RobotDescriptionError(f'{key}.anchors: missing')

        def body(sec: Mapping[str, Any], key: str) -> RigidBodyInertia:
            default = RigidBodyInertia()
            return RigidBodyInertia(
                mass=_as_scalar(sec.get('mass', default.mass), f'{key}.mass', positive=True),
                com=_as_array(sec.get('com', default.com), (3,), f'{key}.com'),
                inertia=_as_array(sec.get('inertia', default.inertia), (3, 3), f'{key}.inertia'))

        def link(key: str) -> LinkInertia:
            sec = section(key, legs, 'legs.')
            default = LinkInertia()
            return LinkInertia(**{
                name: _as_scalar(sec.get(name, getattr(default, name)), f'legs.{key}.{name}')
                for name in ('mass', 'com_from_joint', 'inertia_transverse', 'inertia_axial')})

        kwargs: dict[str, Any] = {
            'name': str(data.get('name', 'custom')),
            'description': str(data.get('description', '')),
            'ring_a_anchors': _as_array(ring_a['anchors'], (6, 3), 'ring_a.anchors'),
            'ring_b_anchors': _as_array(ring_b['anchors'], (6, 3), 'ring_b.anchors'),
            'ring_a_inertia': body(ring_a, 'ring_a'),
            'ring_b_inertia': body(ring_b, 'ring_b'),
            'lower_link': link('lower'),
            'upper_link': link('upper'),
            'grippers': {'ring_a': str(ring_a.get('gripper', 'clamp')),
                         'ring_b': str(ring_b.get('gripper', 'clamp'))},
        }
        for key in ('joint_axes',):
            if key in ring_a:
                kwargs['ring_a_joint_axes'] = _as_array(ring_a[key], (6, 3), f'ring_a.{key}')
            if key in ring_b:
                kwargs['ring_b_joint_axes'] = _as_array(ring_b[key], (6, 3), f'ring_b.{key}')
        for yaml_key, attr in (('min_length', 'min_length'), ('max_length', 'max_length'),
                               ('max_speed', 'max_speed'), ('max_force', 'max_force'),
                               ('radius', 'leg_radius'),
                               ('universal_max_angle', 'universal_max_angle'),
                               ('spherical_max_angle', 'spherical_max_angle')):
            if yaml_key in legs:
                kwargs[attr] = _as_scalar(legs[yaml_key], f'legs.{yaml_key}')
        if 'gravity' in data:
            kwargs['gravity'] = _as_array(data['gravity'], (3,), 'gravity')
        home = section('home')
        if 'position' in home:
            kwargs['home_position'] = _as_array(home['position'], (3,), 'home.position')
        if 'quaternion' in home:
            kwargs['home_quaternion_xyzw'] = _as_array(home['quaternion'], (4,), 'home.quaternion')
        limits = section('limits')
        if 'min_conditioning' in limits:
            kwargs['min_conditioning'] = _as_scalar(limits['min_conditioning'],
                                                    'limits.min_conditioning')
        extra = section('extra_dof')
        dofs = {}
        for ring, sec in extra.items():
            if not isinstance(sec, Mapping):
                raise RobotDescriptionError(f'extra_dof.{ring}: expected a mapping')
            dofs[ring] = ExtraRingDof(
                axis=_as_array(sec.get('axis', [0, 0, 1]), (3,), f'extra_dof.{ring}.axis'),
                min_angle=_as_scalar(sec.get('min_angle', -math.pi), f'extra_dof.{ring}.min_angle'),
                max_angle=_as_scalar(sec.get('max_angle', math.pi), f'extra_dof.{ring}.max_angle'))
        kwargs['extra_dof'] = dofs
        if 'tool' in data:
            sec = section('tool')
            default = Tool()
            size = sec.get('size', default.size)
            if not isinstance(size, (list, tuple)):
                raise RobotDescriptionError(f'tool.size: expected a list of numbers, got {size!r}')
            kwargs['tool'] = Tool(
                name=str(sec.get('name', default.name)),
                position=_as_array(sec.get('position', default.position), (3,), 'tool.position'),
                quaternion_xyzw=_as_array(sec.get('quaternion', default.quaternion_xyzw), (4,),
                                          'tool.quaternion'),
                mass=_as_scalar(sec.get('mass', default.mass), 'tool.mass', positive=True),
                com=_as_array(sec.get('com', default.com), (3,), 'tool.com'),
                inertia=_as_array(sec.get('inertia', default.inertia), (3, 3), 'tool.inertia'),
                shape=str(sec.get('shape', default.shape)), size=tuple(size))
        return cls(**kwargs)

    @classmethod
    def from_yaml(cls, path: str | Path) -> 'RobotGeometry':
        """Load a robot description file (see ``robots/*.yaml`` for the schema)."""
        path = Path(path)
        try:
            text = path.read_text()
        except OSError as exc:
            raise RobotDescriptionError(f'{path}: cannot read: {exc.strerror}') from None
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise RobotDescriptionError(f'{path}: invalid YAML: {exc}') from None
        return cls.from_dict(data, source=str(path))


def shipped_robots() -> list[str]:
    """Names of the robot descriptions shipped with rrps_kinematics."""
    folder = resources.files('rrps_kinematics') / 'robots'
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith('.yaml'))


def robot_path(name_or_path: str | Path) -> Path:
    """Path of a shipped robot (by name, e.g. ``pole_climber``) or of a YAML file."""
    text = str(name_or_path)
    if text.endswith(('.yaml', '.yml')) or '/' in text:
        return Path(text)
    path = Path(str(resources.files('rrps_kinematics') / 'robots' / f'{text}.yaml'))
    if not path.exists():
        raise RobotDescriptionError(
            f'unknown robot {text!r}: not a YAML path and not one of {shipped_robots()}')
    return path


def load_robot(name_or_path: str | Path) -> RobotGeometry:
    """Load a shipped robot by name or a robot description file by path."""
    return RobotGeometry.from_yaml(robot_path(name_or_path))
