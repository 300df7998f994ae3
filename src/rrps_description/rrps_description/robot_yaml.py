"""The robot description's YAML schema (``robots/*.yaml``): reading a file, and turning its
sections (ring_a, ring_b, legs, home, limits, extra_dof, tool, payload, tool_wrench, bus) into
the keyword arguments of :class:`rrps_description.geometry.RobotGeometry`; errors name the key."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

import yaml

from rrps_description.bus import bus_from
from rrps_description.loads import loads_from
from rrps_description.motion_limits import motion_limits_from
from rrps_description.robot_parts import (
    RobotDescriptionError,
    as_array,
    as_scalar,
    body_from,
    extra_dof_from,
    leg_limits_from,
    link_from,
    tool_from,
)

__all__ = ['GRAVITY_MIGRATION', 'geometry_arguments', 'read_description']

#: libyaml's safe loader where PyYAML has it (the same data, faster), else PyYAML's own.
_YAML_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)

#: Why a robot description may not give gravity, and what to do instead.
GRAVITY_MIGRATION = (
    'gravity: a robot description no longer gives gravity, the world does (0, 0, -9.81 m/s^2 '
    "along the world's -z). Remove the 'gravity:' key and pass the supporting ring's attitude "
    'in the world instead: rrps-dynamics ... --support ring_a|ring_b --support-quaternion '
    'QX,QY,QZ,QW, or support= and world_q_support= of the rrps_sim functions')


def read_description(path: Path) -> Any:
    """The parsed YAML of a robot description file; an unreadable file or invalid YAML is a
    RobotDescriptionError naming the file."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise RobotDescriptionError(f'{path}: cannot read: {exc.strerror}') from None
    try:
        return yaml.load(text, Loader=_YAML_LOADER)
    except yaml.YAMLError as exc:
        raise RobotDescriptionError(f'{path}: invalid YAML: {exc}') from None


def geometry_arguments(data: Mapping[str, Any], source: str) -> dict[str, Any]:
    """RobotGeometry's keyword arguments from the parsed YAML schema ``data`` of ``source``."""
    if not isinstance(data, Mapping):
        raise RobotDescriptionError('top level: expected a mapping')
    if 'gravity' in data:
        raise RobotDescriptionError(GRAVITY_MIGRATION)
    known = {'name', 'description', 'ring_a', 'ring_b', 'legs', 'home', 'limits',
             'extra_dof', 'tool', 'payload', 'tool_wrench', 'bus'}
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

    kwargs: dict[str, Any] = {
        'name': str(data.get('name', 'custom')),
        'description': str(data.get('description', '')),
        'ring_a_anchors': as_array(ring_a['anchors'], (6, 3), 'ring_a.anchors'),
        'ring_b_anchors': as_array(ring_b['anchors'], (6, 3), 'ring_b.anchors'),
        'ring_a_inertia': body_from(ring_a, 'ring_a'),
        'ring_b_inertia': body_from(ring_b, 'ring_b'),
        'lower_link': link_from(section('lower', legs, 'legs.'), 'lower'),
        'upper_link': link_from(section('upper', legs, 'legs.'), 'upper'),
        'grippers': {'ring_a': str(ring_a.get('gripper', 'clamp')),
                     'ring_b': str(ring_b.get('gripper', 'clamp'))},
    }
    for key in ('joint_axes',):
        if key in ring_a:
            kwargs['ring_a_joint_axes'] = as_array(ring_a[key], (6, 3), f'ring_a.{key}')
        if key in ring_b:
            kwargs['ring_b_joint_axes'] = as_array(ring_b[key], (6, 3), f'ring_b.{key}')
    kwargs.update(leg_limits_from(legs))
    kwargs.update(motion_limits_from(legs, ring_a, ring_b))
    kwargs.update(loads_from(data, ring_a, ring_b))
    home = section('home')
    if 'position' in home:
        kwargs['home_position'] = as_array(home['position'], (3,), 'home.position')
    if 'quaternion' in home:
        kwargs['home_quaternion_xyzw'] = as_array(home['quaternion'], (4,), 'home.quaternion')
    limits = section('limits')
    if 'min_conditioning' in limits:
        kwargs['min_conditioning'] = as_scalar(limits['min_conditioning'],
                                                'limits.min_conditioning')
    kwargs['extra_dof'] = extra_dof_from(section('extra_dof'))
    if 'tool' in data:
        kwargs['tool'] = tool_from(section('tool'))
    kwargs['bus'] = bus_from(data['bus'], min_length=kwargs.get('min_length', 0.0),
                             max_length=kwargs.get('max_length', math.inf),
                             source=source if source != '<dict>' else '') if 'bus' in data else None
    return kwargs
