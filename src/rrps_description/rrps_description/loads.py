"""What a robot carries and what its grippers hold: a payload on a ring, a wrench at the tool-centre
point, and each gripper's holding capacity (the optional YAML sections ``payload``, ``tool_wrench``
and ``ring_a.holding`` / ``ring_b.holding``: docs/robot-model.md, 'The robot YAML'). Every reader
names the offending key in its :class:`RobotDescriptionError`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from rrps_description.names import RINGS
from rrps_description.robot_parts import RobotDescriptionError, as_array, as_scalar

__all__ = ['Payload', 'WRENCH_FRAMES', 'ToolWrench', 'FRICTION_KEYS', 'LIMIT_KEYS', 'GripperCapacity',
           'payload_from', 'tool_wrench_from', 'capacity_from', 'check_payload', 'loads_from',
           'payload_from_parameters']


@dataclass(frozen=True, kw_only=True)
class Payload:
    """A payload fixed to ``ring`` (ring_a or ring_b): ``mass`` [kg], ``com`` [m] and ``inertia``
    about the com [kg m²] in that ring's frame (zero inertia: a point mass)."""

    ring: str = 'ring_b'
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))


#: Frames a tool wrench may be given in: the tool frame (it turns with the tool, e.g. a drilling
#: thrust along the tool's axis) or the world frame (e.g. a hanging hose's weight).
WRENCH_FRAMES = ('tool', 'world')


@dataclass(frozen=True, kw_only=True)
class ToolWrench:
    """An external wrench on ring_b at the tool-centre point: ``force`` [N] and ``torque`` [N m]
    that the environment applies to the tool, in ``frame`` ('tool' or 'world')."""

    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: np.ndarray = field(default_factory=lambda: np.zeros(3))
    frame: str = 'tool'


FRICTION_KEYS = ('clamp_force', 'friction', 'radius')
LIMIT_KEYS = ('axial_force', 'shear_force', 'torque')


@dataclass(frozen=True, kw_only=True)
class GripperCapacity:
    """What a gripper holds, in its ring's frame (z the ring axis), moments about ``contact`` [m]: a
    friction clamp (``clamp_force`` N [N], ``friction`` μ, ``radius`` r [m]; it holds while
    √(F_z² + (M_z / r)²) <= μ N) or rated limits (``axial_force`` [N] pulling it off along -z,
    ``shear_force`` [N] along the surface, ``torque`` [N m] about the contact)."""

    clamp_force: float | None = None
    friction: float | None = None
    radius: float | None = None
    axial_force: float | None = None
    shear_force: float | None = None
    torque: float | None = None
    contact: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def kind(self) -> str:
        """'friction' or 'limits'."""
        return 'friction' if self.clamp_force is not None else 'limits'


def check_payload(payload: Payload) -> Payload:
    """The payload with validated arrays; RobotDescriptionError naming the key otherwise."""
    if payload.ring not in RINGS:
        raise RobotDescriptionError(f"payload.ring: must be 'ring_a' or 'ring_b', got {payload.ring!r}")
    mass = as_scalar(payload.mass, 'payload.mass', nonnegative=True)
    inertia = as_array(payload.inertia, (3, 3), 'payload.inertia')
    if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12):
        raise RobotDescriptionError('payload.inertia: inertia must be symmetric')
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] < -1e-12 or eig[0] + eig[1] < eig[2] * (1.0 - 1e-9) - 1e-12:
        raise RobotDescriptionError(f'payload.inertia: not a physical inertia (principal moments {eig})')
    return Payload(ring=payload.ring, mass=mass, com=as_array(payload.com, (3,), 'payload.com'),
                   inertia=inertia)


def payload_from_parameters(values: Mapping[str, Any]) -> Payload | None:
    """The point-mass payload of a node's parameters ``payload_mass`` [kg], ``payload_ring`` and
    ``payload_com`` [m] (in that ring's frame); None for a mass of 0 (the robot description's
    payload stays). ValueError naming the parameter when one is malformed."""
    mass = float(values['payload_mass'])
    if mass == 0.0:
        return None
    com = np.asarray(values['payload_com'], dtype=float)
    if com.shape != (3,) or not np.all(np.isfinite(com)):
        raise ValueError(f"payload_com must be 3 finite numbers [m], got {values['payload_com']}")
    if not (math.isfinite(mass) and mass > 0.0):
        raise ValueError(f'payload_mass must be finite and >= 0 [kg], got {mass}')
    return check_payload(Payload(ring=values['payload_ring'], mass=mass, com=com))


def _known(sec: Mapping[str, Any], keys, where: str) -> None:
    unknown = set(sec) - set(keys)
    if unknown:
        raise RobotDescriptionError(f'{where}: unknown keys {sorted(unknown)} (known: {", ".join(keys)})')


def payload_from(sec: Mapping[str, Any]) -> Payload:
    """The YAML ``payload`` section."""
    _known(sec, ('ring', 'mass', 'com', 'inertia'), 'payload')
    if 'mass' not in sec:
        raise RobotDescriptionError('payload.mass: missing')
    return check_payload(Payload(ring=str(sec.get('ring', 'ring_b')), mass=sec['mass'],
                                 com=sec.get('com', np.zeros(3)),
                                 inertia=sec.get('inertia', np.zeros((3, 3)))))


def tool_wrench_from(sec: Mapping[str, Any]) -> ToolWrench:
    """The YAML ``tool_wrench`` section."""
    _known(sec, ('force', 'torque', 'frame'), 'tool_wrench')
    frame = str(sec.get('frame', 'tool'))
    if frame not in WRENCH_FRAMES:
        raise RobotDescriptionError(f'tool_wrench.frame: must be one of {WRENCH_FRAMES}, got {frame!r}')
    return ToolWrench(force=as_array(sec.get('force', np.zeros(3)), (3,), 'tool_wrench.force'),
                      torque=as_array(sec.get('torque', np.zeros(3)), (3,), 'tool_wrench.torque'),
                      frame=frame)


def capacity_from(sec: Any, ring: str) -> GripperCapacity:
    """A ring's YAML ``holding`` section: all of FRICTION_KEYS or all of LIMIT_KEYS, and an
    optional ``contact``."""
    key = f'{ring}.holding'
    if not isinstance(sec, Mapping):
        raise RobotDescriptionError(f'{key}: expected a mapping')
    _known(sec, FRICTION_KEYS + LIMIT_KEYS + ('contact',), key)
    contact = as_array(sec.get('contact', np.zeros(3)), (3,), f'{key}.contact')
    for keys in (FRICTION_KEYS, LIMIT_KEYS):
        if set(keys) <= set(sec) and not set(sec) & (set(FRICTION_KEYS + LIMIT_KEYS) - set(keys)):
            values = {k: as_scalar(sec[k], f'{key}.{k}', positive=True) for k in keys}
            return GripperCapacity(contact=contact, **values)
    raise RobotDescriptionError(f'{key}: give either {", ".join(FRICTION_KEYS)} (a friction clamp) '
                                f'or {", ".join(LIMIT_KEYS)} (rated limits), got {sorted(sec)}')


def loads_from(data: Mapping[str, Any], ring_a: Mapping[str, Any], ring_b: Mapping[str, Any]) -> dict[str, Any]:
    """RobotGeometry keyword arguments of the optional YAML sections: ``payload``,
    ``tool_wrench`` and the rings' ``holding``."""
    kwargs: dict[str, Any] = {'holding': {ring: capacity_from(sec['holding'], ring)
                                          for ring, sec in (('ring_a', ring_a), ('ring_b', ring_b))
                                          if 'holding' in sec}}
    for key, reader in (('payload', payload_from), ('tool_wrench', tool_wrench_from)):
        if key in data:
            if not isinstance(data[key], Mapping):
                raise RobotDescriptionError(f'{key}: expected a mapping')
            kwargs[key] = reader(data[key])
    return kwargs
