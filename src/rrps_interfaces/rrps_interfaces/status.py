"""The typed status-value contract of every rrps node, and the /diagnostics topic (no ROS import):
``diagnostic_msgs/KeyValue`` strings typed by a :class:`StatusValues` dataclass (its fields are the
keys), encoded by :func:`encode_value`, read back by :meth:`StatusValues.from_values` (a missing or
malformed key raises :class:`ContractError`)."""

from __future__ import annotations

import dataclasses
import enum
import typing
from typing import Any, ClassVar, Mapping

__all__ = ['DIAGNOSTICS', 'ContractError', 'encode_value', 'decode_value', 'StatusValues', 'source_node',
           'CommandAgeStatus', 'SchedulingStatus']

#: diagnostic_msgs/DiagnosticArray: every node's status (REP-107).
DIAGNOSTICS = '/diagnostics'


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
class SchedulingStatus(StatusValues):
    """The scheduling a node's command path got (every node that claims one reports it with its
    own status): the policy ('SCHED_RR' or 'SCHED_OTHER'), its priority, the nice value, the
    CPUs, and why less than asked was granted ('' when all of it was)."""

    scheduling_policy: str
    scheduling_priority: int = 0
    scheduling_nice: int = 0
    scheduling_cpus: tuple[int, ...] = ()
    scheduling_refused: str = ''
