"""One declaration per node parameter: name, type, default, unit, range, choices, description.

A node's :class:`NodeParameters` is the single source of its ROS parameter descriptors
(:func:`rrps_runtime.parameters.declare_parameters`), its shipped ``rrps_bringup/config/<node>.yaml``
(:meth:`NodeParameters.config_yaml`) and its table in docs/parameters.md (:meth:`NodeParameters.markdown`),
as generate_parameter_library does for moveit_servo. Pure Python, no ROS import.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import yaml

__all__ = ['Parameter', 'NodeParameters', 'ROBOT', 'PAYLOAD', 'format_value']

_TYPES = (bool, int, float, str, tuple)


@dataclass(frozen=True)
class Parameter:
    """One parameter of a node: ``default`` fixes the type (``None`` with ``type``: unset, the node derives it);
    ``range`` bounds a number (inclusive), ``choices`` a string; only ``dynamic`` ones may be set while it runs."""

    name: str
    default: bool | int | float | str | tuple | None
    description: str
    unit: str = ''
    range: tuple[float, float] | None = None
    choices: tuple[str, ...] = ()
    dynamic: bool = False
    type: type | None = None
    #: the node derives the default when the value is unset (documented in the file, not set there)
    unset_note: str = ''
    #: the type of a list parameter's items: float, int or str (None: str for a default of
    #: strings, else float)
    item_type: type | None = None

    def __post_init__(self) -> None:
        kind = self.type or type(self.default)
        if self.default is None and self.type is None:
            raise ValueError(f'{self.name}: a parameter without a default needs its type')
        if kind not in _TYPES:
            raise ValueError(f'{self.name}: unsupported type {kind.__name__}')
        object.__setattr__(self, 'type', kind)
        if self.default is not None and not isinstance(self.default, kind):
            raise ValueError(f'{self.name}: default {self.default!r} is not a {kind.__name__}')
        if kind is tuple:
            item = self.item_type or (str if self.default and all(isinstance(v, str) for v in self.default)
                                      else float)
            object.__setattr__(self, 'item_type', item)
            if item not in (float, int, str):
                raise ValueError(f'{self.name}: a list parameter holds floats, ints or strings')
            if not all(isinstance(v, str) if item is str else
                       (isinstance(v, (int, float)) and not isinstance(v, bool)
                        and (item is float or isinstance(v, int)))
                       for v in self.default or ()):
                raise ValueError(f'{self.name}: a list parameter holds {item.__name__}s')
            if item is str and self.range is not None:
                raise ValueError(f'{self.name}: a range needs a number type')
        if self.range is not None:
            lo, hi = self.range
            if kind not in (int, float, tuple) or not lo <= hi:
                raise ValueError(f'{self.name}: a range needs a number type and lo <= hi')
        if self.choices and kind is not str:
            raise ValueError(f'{self.name}: choices are for strings')
        if self.default is not None:
            self.check(self.default)

    @property
    def read_only(self) -> bool:
        return not self.dynamic

    def check(self, value) -> None:
        """ValueError naming the parameter when ``value`` is outside its range or choices."""
        if self.choices and value not in self.choices:
            raise ValueError(f'{self.name} must be one of {" | ".join(self.choices)}, got {value!r}')
        if self.range is not None:
            lo, hi = self.range
            values = value if isinstance(value, (tuple, list)) else (value,)
            for v in values:
                if not (isinstance(v, (int, float)) and lo <= v <= hi):
                    raise ValueError(f'{self.name} must be in [{_bound(lo)}, {_bound(hi)}], got {value!r}')

    def constraints(self) -> str:
        """The range or the choices in words ('' when neither)."""
        if self.choices:
            return ' | '.join(self.choices)
        if self.range is not None:
            return f'[{_bound(self.range[0])} .. {_bound(self.range[1])}]'
        return ''

    def summary(self) -> str:
        """The description with unit, range or choices and whether it is read-only."""
        text = self.description + (f' [{self.unit}]' if self.unit else '')
        if self.constraints():
            text += f' {self.constraints()}'
        return text + (' (read-only)' if self.read_only else '')


def _bound(value: float) -> str:
    """A range bound in words: an int as it is, a float in %g."""
    return str(value) if isinstance(value, int) else f'{value:g}'


#: The robot every node serves: a shipped robot's name or the path of a robot YAML.
ROBOT = Parameter('robot', 'pole_climber',
                  'shipped robot name (rrps-kinematics robots) or the path of a robot YAML')

#: A point-mass payload on a ring in place of the robot description's, for every node that
#: computes the robot's loads (the simulated driver, the climb node's plans and previews):
#: ``rrps_description.loads.payload_from_parameters`` reads them.
PAYLOAD = (
    Parameter('payload_mass', 0.0, "a point-mass payload replacing the robot description's; 0: the "
              "description's", unit='kg', range=(0.0, 10000.0)),
    Parameter('payload_ring', 'ring_b', 'the ring carrying payload_mass', choices=('ring_a', 'ring_b')),
    Parameter('payload_com', (0.0, 0.0, 0.0), "payload_mass's centre of mass in its ring's frame", unit='m'),
)


def _quoted(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


def _plain(text: str) -> bool:
    """Whether YAML reads ``text`` unquoted as this very string."""
    try:
        return bool(text) and text.strip() == text and yaml.safe_load(text) == text
    except yaml.YAMLError:
        return False


def format_value(value) -> str:
    """A value as the YAML files and the docs write it (a string quoted where YAML would read it
    as something else, and inside lists)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        if math.isinf(value) or math.isnan(value):
            return '.nan' if math.isnan(value) else '.inf' if value > 0 else '-.inf'
        mantissa, e, exponent = repr(value).partition('e')
        if '.' not in mantissa:  # YAML 1.1 (PyYAML) reads 1e-12 as text, 1.0e-12 as a float
            mantissa += '.0'
        return mantissa + e + exponent
    if isinstance(value, (tuple, list)):
        return '[' + ', '.join(_quoted(v) if isinstance(v, str) else
                               str(v) if isinstance(v, int) else format_value(float(v))
                               for v in value) + ']'
    if isinstance(value, str):
        return value if _plain(value) else _quoted(value)
    return str(value)


@dataclass(frozen=True)
class NodeParameters:
    """The parameters of one node, in declaration order."""

    node: str
    package: str
    parameters: Sequence[Parameter] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        object.__setattr__(self, 'parameters', tuple(self.parameters))
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise ValueError(f'{self.node}: a parameter is declared twice')

    def __iter__(self) -> Iterator[Parameter]:
        return iter(self.parameters)

    def __getitem__(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def defaults(self) -> dict:
        """{name: default} (None for the parameters left unset)."""
        return {p.name: p.default for p in self.parameters}

    def config_yaml(self) -> str:
        """The node's parameter file: every parameter with its default and its description."""
        out = [f'# {self.node} ({self.package}): every parameter with its default. Generated from',
               '# the node\'s parameter schema by `rrps-params --write`; load it with',
               f'#   ros2 run {self.package} {self.node} --ros-args --params-file <this file>',
               f'# The section /**/{self.node} applies to a node of that name in any namespace, so',
               '# the files of several nodes can be given to one composed process (rrps-compose).',
               f'/**/{self.node}:', '  ros__parameters:']
        for p in self.parameters:
            out += textwrap.wrap(p.summary(), width=96, initial_indent='    # ',
                                 subsequent_indent='    # ', break_on_hyphens=False)
            if p.default is None:
                out.append(f'    # {p.name}: unset here: {p.unset_note}')
            else:
                out.append(f'    {p.name}: {format_value(p.default)}')
        return '\n'.join(out) + '\n'

    def markdown(self) -> str:
        """A Markdown table of the parameters (name, default, unit, range or choices, run time)."""
        rows = [f'### {self.node} ({self.package})', '',
                '| parameter | default | unit | range / choices | settable at run time | description |',
                '|---|---|---|---|---|---|']
        def cell(text: str) -> str:
            return text.replace('|', '\\|')
        for p in self.parameters:
            default = p.unset_note if p.default is None else f'`{format_value(p.default)}`'
            rows.append(f'| `{p.name}` | {cell(default)} | {p.unit} | {cell(p.constraints())} | '
                        f'{"yes" if p.dynamic else "no"} | {cell(p.description)} |')
        return '\n'.join(rows) + '\n'
