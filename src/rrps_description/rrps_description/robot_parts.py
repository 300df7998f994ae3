"""The parts of a robot description: bodies, leg links, extra ring DOF, tool, and the checks and
YAML-section readers of their values (used by :mod:`rrps_description.geometry`).

Every reader names the offending key in its :class:`RobotDescriptionError`, e.g.
``legs.lower.mass: must be > 0, got -1.0``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from rrps_description.rotations import normalize_quat, quat_xyzw_to_matrix

__all__ = [
    'RobotDescriptionError',
    'RigidBodyInertia',
    'LinkInertia',
    'ExtraRingDof',
    'TOOL_SHAPES',
    'Tool',
    'combine_bodies',
    'as_array',
    'as_scalar',
    'check_inertia',
    'check_tool',
    'body_from',
    'link_from',
    'leg_limits_from',
    'extra_dof_from',
    'tool_from',
]


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
    """A tool carried by ring_b (the handler arm's tool, §3.2, Fig. 10): ``b_T_tool`` (``position`` [m],
    ``quaternion_xyzw``); ``mass`` [kg], ``com`` [m] and ``inertia`` [kg m^2, about the com] in the tool
    frame; ``shape`` and ``size`` [m] only draw it (docs/robot-model.md, 'The robot YAML')."""

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


def as_array(value: Any, shape: tuple[int, ...], key: str) -> np.ndarray:
    """A read-only float array of ``shape``, finite; RobotDescriptionError naming ``key`` otherwise."""
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


def as_scalar(value: Any, key: str, *, positive: bool = False, nonnegative: bool = False) -> float:
    """A finite float (> 0 or >= 0 when asked); RobotDescriptionError naming ``key`` otherwise."""
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


def check_inertia(inertia: np.ndarray, key: str) -> None:
    """RobotDescriptionError naming ``key`` unless ``inertia`` is a physical inertia tensor (symmetric,
    positive definite, principal moments obeying the triangle inequality)."""
    if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12):
        raise RobotDescriptionError(f'{key}: inertia must be symmetric')
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] <= 0.0:
        raise RobotDescriptionError(f'{key}: inertia must be positive definite (eigenvalues {eig})')
    if eig[0] + eig[1] < eig[2] * (1.0 - 1e-9):
        raise RobotDescriptionError(f'{key}: principal moments break the triangle inequality {eig}')


def check_tool(t: Tool) -> None:
    """Validate a :class:`Tool` in place (its arrays made read-only floats, its quaternion
    normalised); RobotDescriptionError naming the ``tool.`` key otherwise."""
    object.__setattr__(t, 'position', as_array(t.position, (3,), 'tool.position'))
    q = as_array(t.quaternion_xyzw, (4,), 'tool.quaternion')
    if abs(np.linalg.norm(q) - 1.0) > 1e-6:
        raise RobotDescriptionError('tool.quaternion: must be a unit quaternion (x, y, z, w)')
    object.__setattr__(t, 'quaternion_xyzw', normalize_quat(q))
    as_scalar(t.mass, 'tool.mass', positive=True)
    object.__setattr__(t, 'com', as_array(t.com, (3,), 'tool.com'))
    object.__setattr__(t, 'inertia', as_array(t.inertia, (3, 3), 'tool.inertia'))
    check_inertia(t.inertia, 'tool.inertia')
    if t.shape not in TOOL_SHAPES:
        raise RobotDescriptionError(f'tool.shape: must be one of {TOOL_SHAPES}, got {t.shape!r}')
    size = tuple(as_scalar(v, 'tool.size', positive=True) for v in t.size)
    wanted = {'cylinder': 2, 'box': 3, 'sphere': 1}[t.shape]
    if len(size) != wanted:
        raise RobotDescriptionError(f'tool.size: a {t.shape} takes {wanted} sizes, got {len(size)}')
    object.__setattr__(t, 'size', size)


def body_from(sec: Mapping[str, Any], key: str) -> RigidBodyInertia:
    """A ring's inertia from its YAML section (defaults where not given)."""
    default = RigidBodyInertia()
    return RigidBodyInertia(
        mass=as_scalar(sec.get('mass', default.mass), f'{key}.mass', positive=True),
        com=as_array(sec.get('com', default.com), (3,), f'{key}.com'),
        inertia=as_array(sec.get('inertia', default.inertia), (3, 3), f'{key}.inertia'))


def link_from(sec: Mapping[str, Any], key: str) -> LinkInertia:
    """A leg link's inertia from the YAML ``legs.lower`` / ``legs.upper`` section."""
    default = LinkInertia()
    return LinkInertia(**{
        name: as_scalar(sec.get(name, getattr(default, name)), f'legs.{key}.{name}')
        for name in ('mass', 'com_from_joint', 'inertia_transverse', 'inertia_axial')})


def leg_limits_from(legs: Mapping[str, Any]) -> dict[str, float]:
    """RobotGeometry keyword arguments of the YAML ``legs`` limits that are given."""
    return {attr: as_scalar(legs[yaml_key], f'legs.{yaml_key}')
            for yaml_key, attr in (('min_length', 'min_length'), ('max_length', 'max_length'),
                                   ('max_speed', 'max_speed'), ('max_force', 'max_force'),
                                   ('radius', 'leg_radius'),
                                   ('universal_max_angle', 'universal_max_angle'),
                                   ('spherical_max_angle', 'spherical_max_angle'))
            if yaml_key in legs}


def extra_dof_from(extra: Mapping[str, Any]) -> dict[str, ExtraRingDof]:
    """The YAML ``extra_dof`` section: a ring rotation per ring that has one."""
    dofs = {}
    for ring, sec in extra.items():
        if not isinstance(sec, Mapping):
            raise RobotDescriptionError(f'extra_dof.{ring}: expected a mapping')
        dofs[ring] = ExtraRingDof(
            axis=as_array(sec.get('axis', [0, 0, 1]), (3,), f'extra_dof.{ring}.axis'),
            min_angle=as_scalar(sec.get('min_angle', -math.pi), f'extra_dof.{ring}.min_angle'),
            max_angle=as_scalar(sec.get('max_angle', math.pi), f'extra_dof.{ring}.max_angle'))
    return dofs


def tool_from(sec: Mapping[str, Any]) -> Tool:
    """The YAML ``tool`` section: its frame in ring_b, inertia and shape."""
    default = Tool()
    size = sec.get('size', default.size)
    if not isinstance(size, (list, tuple)):
        raise RobotDescriptionError(f'tool.size: expected a list of numbers, got {size!r}')
    return Tool(
        name=str(sec.get('name', default.name)),
        position=as_array(sec.get('position', default.position), (3,), 'tool.position'),
        quaternion_xyzw=as_array(sec.get('quaternion', default.quaternion_xyzw), (4,), 'tool.quaternion'),
        mass=as_scalar(sec.get('mass', default.mass), 'tool.mass', positive=True),
        com=as_array(sec.get('com', default.com), (3,), 'tool.com'),
        inertia=as_array(sec.get('inertia', default.inertia), (3, 3), 'tool.inertia'),
        shape=str(sec.get('shape', default.shape)), size=tuple(size))
