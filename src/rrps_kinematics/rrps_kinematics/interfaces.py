"""The contract between rrps nodes, kinematics part: names, frames and typed status values.

Nodes talk through these names and types, never through another node's human-readable text.
Topic names are relative (the deployments put them under a namespace such as ``/rrps``)::

    TARGET_POSE        geometry_msgs/PoseStamped  a_T_b, frame RING_A_FRAME   command stream
    TARGET_RINGS       sensor_msgs/JointState     extra-DOF ring angles [rad] command stream
                       (joints ring_a_rotation, ring_b_rotation: robots with the extra DOF)
    ACTUATORS_COMMAND  sensor_msgs/JointState     leg lengths [m], LEG_NAMES  command stream
    ACTUATORS_STATE    sensor_msgs/JointState     lengths, rates, forces      state stream
    POSE               geometry_msgs/PoseStamped  a_T_b from FK               state stream
    DIAGNOSTICS        diagnostic_msgs/DiagnosticArray                        state stream
    ~/RECORDING_TAP    std_msgs/UInt8MultiArray   a node's published messages, batched for a
                       recorder (:mod:`rrps_kinematics.recording_bundle`); only while one listens

A node's status values travel as ``diagnostic_msgs/KeyValue`` strings; :class:`StatusValues`
gives them types: a dataclass whose fields are the keys, encoded by :func:`encode_value` and
read back, typed, by :meth:`StatusValues.from_values` (a missing or malformed key raises
:class:`ContractError`). Each node's status is one such class (:class:`IkStatus`,
:class:`FkStatus` here; the simulator's and the teleoperation's in their packages'
``interfaces`` modules).

Pure Python, no ROS import.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import typing
from typing import Any, ClassVar, Mapping

__all__ = [
    'TARGET_POSE', 'TARGET_RINGS', 'ring_joint', 'ACTUATORS_COMMAND', 'ACTUATORS_STATE', 'POSE', 'DIAGNOSTICS',
    'RECORDING_TAP',
    'RING_A_FRAME', 'RING_B_FRAME', 'WORLD_FRAME', 'LEG_NAMES',
    'ContractError', 'encode_value', 'decode_value', 'StatusValues', 'source_node',
    'CommandAgeStatus', 'IkStatus', 'FkStatus',
]

TARGET_POSE = 'target_pose'
TARGET_RINGS = 'target_rings'
ACTUATORS_COMMAND = 'actuators/command'
ACTUATORS_STATE = 'actuators/state'
POSE = 'pose'
DIAGNOSTICS = '/diagnostics'
#: A node's private topic of recording bundles: ``<namespace>/<node>/recording_tap``.
RECORDING_TAP = 'recording_tap'

RING_A_FRAME = 'ring_a'
RING_B_FRAME = 'ring_b'
WORLD_FRAME = 'world'

#: Joint names of the six legs, in leg order.
LEG_NAMES = tuple(f'leg_{i}' for i in range(1, 7))


def ring_joint(ring: str) -> str:
    """Joint name of a ring's extra DOF (its angle about the ring axis, rad) in the actuator
    streams of robots that have one (paper section 3.1, Figure 9)."""
    if ring not in ('ring_a', 'ring_b'):
        raise ValueError(f"ring must be 'ring_a' or 'ring_b', got {ring!r}")
    return f'{ring}_rotation'


class ContractError(ValueError):
    """A status value that is missing or does not have its declared type."""


def encode_value(value: Any) -> str:
    """The KeyValue text of a status value: enums by member name, booleans 'true'/'false',
    floats with 9 significant digits, sequences comma-separated, None as ''."""
    if value is None:
        return ''
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return f'{value:.9g}'
    if isinstance(value, (tuple, list)):
        return ','.join(encode_value(v) for v in value)
    return str(value)


def decode_value(text: str, kind: Any) -> Any:
    """Read ``text`` back as ``kind`` (a type annotation): the inverse of :func:`encode_value`."""
    origin = typing.get_origin(kind)
    args = typing.get_args(kind)
    if origin is typing.Union or (origin is not None and type(None) in args):
        inner = [a for a in args if a is not type(None)]
        return None if text == '' else decode_value(text, inner[0])
    if origin is tuple:
        item = args[0] if args else str
        return tuple(decode_value(t, item) for t in text.split(',')) if text else ()
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        try:
            return kind[text]
        except KeyError:
            raise ContractError(f'{text!r} is not a {kind.__name__} '
                                f'({", ".join(m.name for m in kind)})') from None
    if kind is bool:
        if text not in ('true', 'false'):
            raise ContractError(f"{text!r} is not a boolean ('true' or 'false')")
        return text == 'true'
    if kind in (int, float, str):
        try:
            return kind(text)
        except ValueError:
            raise ContractError(f'{text!r} is not a {kind.__name__}') from None
    raise TypeError(f'no decoding for {kind!r}')


class StatusValues:
    """Base of the typed status classes (dataclasses whose fields are the KeyValue keys)."""

    _hints: ClassVar[dict | None] = None

    @classmethod
    def _types(cls) -> dict:
        if cls.__dict__.get('_hints') is None:
            cls._hints = typing.get_type_hints(cls)
        return cls._hints

    def to_values(self) -> dict[str, str]:
        """{key: text} for a DiagnosticStatus' KeyValues, in field order."""
        return {f.name: encode_value(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_values(cls, values: Mapping[str, str]):
        """The typed status from {key: text}; ContractError when a required key is missing or
        a value does not decode (fields with defaults may be absent; unknown keys are ignored)."""
        types = cls._types()
        kwargs = {}
        for f in dataclasses.fields(cls):
            if f.name not in values:
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                    raise ContractError(f'{cls.__name__}: missing key {f.name!r}')
                continue
            try:
                kwargs[f.name] = decode_value(values[f.name], types[f.name])
            except ContractError as exc:
                raise ContractError(f'{cls.__name__}.{f.name}: {exc}') from None
        return cls(**kwargs)

    @classmethod
    def from_key_values(cls, key_values):
        """From a sequence of objects with ``key`` and ``value`` (diagnostic_msgs/KeyValue)."""
        return cls.from_values({kv.key: kv.value for kv in key_values})


def source_node(status_name: str) -> str:
    """The node that published a DiagnosticStatus (its name is ``'<node>: <what>'``)."""
    return status_name.split(':', 1)[0].strip()


@dataclasses.dataclass(frozen=True)
class CommandAgeStatus(StatusValues):
    """Ages of the commands a node received (receipt time minus stamp) over the last 10 s."""

    command_count: int = 0
    command_stale_total: int = 0
    command_age_p50_ms: float | None = None
    command_age_p99_ms: float | None = None
    command_age_max_ms: float | None = None


@dataclasses.dataclass(frozen=True)
class IkStatus(CommandAgeStatus):
    """ik_node's /diagnostics values: accepted and rejected targets, the smallest margin of each
    limit at the last accepted target (SI units), the ages of the targets received."""

    accepted: int = 0
    rejected: int = 0
    robot: str = ''
    min_stroke_margin: float = math.nan
    min_universal_margin: float = math.nan
    min_spherical_margin: float = math.nan
    min_interference_margin: float = math.nan
    min_conditioning_margin: float = math.nan


@dataclasses.dataclass(frozen=True)
class FkStatus(StatusValues):
    """fk_node's /diagnostics values: solves, the last solve's convergence and conditioning."""

    solved: int = 0
    failed: int = 0
    converged: bool = False
    iterations: int = 0
    residual: float = math.nan
    singular: bool = False
    continuation: bool = False
    inverse_condition: float | None = None
