"""ROS 2 message definitions as MCAP ``ros2msg`` schemas and their type hashes, from ``rosbags``. No rclpy.

A schema is the recorded type's definition followed by each type it uses, once, separated as rosbag2 (Jazzy)
separates them (a line of ``=`` then ``MSG: pkg/Type``). Definitions and ``RIHS01_...`` hashes come from
rosbags' Jazzy typestore; a type it does not know is read from the ``share/<package>/msg/<Type>.msg`` its
package installs (with its dependencies) and added to it.
"""

from __future__ import annotations

import functools
import importlib
import os
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.base import TypesysError

__all__ = ['SEPARATOR', 'SchemaError', 'message_schema', 'type_hash', 'dependencies', 'message_class']

#: rosbag2's separator line between the definitions of a schema (80 '=').
SEPARATOR = '=' * 80


class SchemaError(LookupError):
    """No definition can be found for a message type."""


@functools.lru_cache(maxsize=None)
def _typestore():
    return get_typestore(Stores.ROS2_JAZZY)


def _installed_msg(type_name: str) -> str:
    """The text of the .msg file of ``pkg/msg/Type`` installed in an ament prefix or beside the
    package (SchemaError if none)."""
    package, _, name = type_name.split('/')
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    prefixes += [sys.prefix, sys.base_prefix]
    try:  # the package's own install prefix (site-packages/<pkg> -> <prefix>/share/<pkg>)
        prefixes += [str(p) for p in Path(importlib.import_module(package).__file__).resolve().parents[:6]]
    except (ImportError, TypeError, AttributeError):
        pass
    for prefix in prefixes:
        path = Path(prefix) / 'share' / package / 'msg' / f'{name}.msg'
        if path.is_file():
            return path.read_text(encoding='utf-8')
    raise SchemaError(f'no definition of {type_name}: not a known type and no installed .msg file')


def _full_name(type_name: str) -> str:
    parts = type_name.split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    if len(parts) == 3 and parts[1] == 'msg':
        return type_name
    raise SchemaError(f'not a message type name: {type_name!r} (expected pkg/msg/Type)')


@functools.lru_cache(maxsize=None)
def message_schema(type_name: str) -> str:
    """The ``ros2msg`` schema text of ``type_name`` ('pkg/msg/Type') with its dependencies."""
    full = _full_name(type_name)
    store = _typestore()
    for _ in range(64):  # each round adds one installed definition the schema still misses
        try:
            return store.generate_msgdef(full, ros_version=2)[0]
        except (KeyError, TypesysError) as exc:
            missing = full if full not in store.fielddefs else _full_name(str(exc.args[0]).strip("'"))
            store.register(get_types_from_msg(_installed_msg(missing), missing))
    raise SchemaError(f'{full}: too many nested definitions')


@functools.lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """The type's ``RIHS01_...`` hash, or '' if it cannot be computed."""
    try:
        message_schema(type_name)
        return _typestore().hash_rihs01(_full_name(type_name))
    except (LookupError, TypesysError):
        return ''


def dependencies(type_name: str) -> list[str]:
    """Every type ``type_name`` uses, transitively, each once, in the schema's order."""
    return [_full_name(line[5:]) for line in message_schema(type_name).splitlines() if line.startswith('MSG: ')]


def message_class(type_name: str):
    """The Python class of ``pkg/msg/Type`` (ImportError / AttributeError when not installed)."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)
