"""ROS 2 message definitions as MCAP ``ros2msg`` schemas, the way rosbag2 writes them.

A schema is the ``.msg`` text of the recorded type followed by the text of every type it uses,
each once, in depth-first order, separated as rosbag2 (Jazzy) and mcap-ros2-support do::

    std_msgs/Header header
    Pose pose
    ================================================================================
    MSG: std_msgs/Header
    ...

The texts come from the ``share/<package>/msg/<Type>.msg`` files that the message packages
install (the ROS wheels ship them), else they are generated from the message class's rosidl
introspection (``get_fields_and_field_types``: field types and names, without the comments and
constants, which decoding does not need). ``tf2_msgs/msg/TFMessage`` is built in
(:data:`BUILTIN_DEFINITIONS`), so recordings carry ``/tf`` without the tf2_msgs package.

The type hash (``RIHS01_...``) of a type is read from the ``.json`` type description beside the
``.msg`` file when there is one. Pure Python, no rclpy import.
"""

from __future__ import annotations

import functools
import importlib
import json
import os
import re
import sys
from pathlib import Path

__all__ = ['BUILTIN_DEFINITIONS', 'SEPARATOR', 'SchemaError', 'split_type_name',
           'message_text', 'message_schema', 'type_hash', 'dependencies',
           'generated_definition', 'message_class']

#: rosbag2's separator line between the definitions of a schema (80 '=').
SEPARATOR = '=' * 80

#: Definitions of types whose package may be missing here (their dependencies must be present).
BUILTIN_DEFINITIONS = {
    'tf2_msgs/msg/TFMessage': 'geometry_msgs/TransformStamped[] transforms\n',
}

_PRIMITIVES = frozenset({
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16', 'int32',
    'uint32', 'int64', 'uint64', 'string', 'wstring', 'time', 'duration'})

# rosidl introspection type names -> .msg names
_IDL_TO_MSG = {'double': 'float64', 'float': 'float32', 'octet': 'byte', 'boolean': 'bool',
               'long double': 'float64'}


class SchemaError(LookupError):
    """No definition can be found for a message type."""


def split_type_name(type_name: str) -> tuple[str, str]:
    """('geometry_msgs', 'Pose') from 'geometry_msgs/msg/Pose' or 'geometry_msgs/Pose'."""
    parts = type_name.split('/')
    if len(parts) == 3 and parts[1] == 'msg':
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise SchemaError(f'not a message type name: {type_name!r} (expected pkg/msg/Type)')


def _full_name(package: str, name: str) -> str:
    return f'{package}/msg/{name}'


def _share_dirs(package: str) -> list[Path]:
    """Where ``share/<package>`` may be: the ament index prefixes, then this interpreter's."""
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    prefixes += [sys.prefix, sys.base_prefix]
    try:  # the package's own install prefix (site-packages/<pkg> -> <prefix>/share/<pkg>)
        module = importlib.import_module(package)
        here = Path(module.__file__).resolve()
        prefixes += [str(parent) for parent in here.parents[:6]]
    except (ImportError, TypeError, AttributeError):
        pass
    seen, out = set(), []
    for prefix in prefixes:
        path = Path(prefix) / 'share' / package
        if path not in seen:
            seen.add(path)
            out.append(path)
    return out


def _msg_file(package: str, name: str, suffix: str) -> Path | None:
    for share in _share_dirs(package):
        path = share / 'msg' / f'{name}{suffix}'
        if path.is_file():
            return path
    return None


def _introspection_type(idl: str, package: str) -> str:
    """A rosidl introspection field type ('sequence<double, 3>', 'geometry_msgs/Pose', ...) in
    .msg syntax ('float64[<=3]', 'geometry_msgs/Pose')."""
    idl = idl.strip()
    m = re.fullmatch(r'sequence<(.+?)(?:,\s*(\d+))?>', idl)
    if m:
        inner = _introspection_type(m.group(1), package)
        return f'{inner}[<={m.group(2)}]' if m.group(2) else f'{inner}[]'
    m = re.fullmatch(r'(.+)\[(\d+)\]', idl)
    if m:
        return f'{_introspection_type(m.group(1), package)}[{m.group(2)}]'
    m = re.fullmatch(r'(w?string)<(\d+)>', idl)
    if m:
        return f'{m.group(1)}<={m.group(2)}'
    if idl in _IDL_TO_MSG:
        return _IDL_TO_MSG[idl]
    return idl


def generated_definition(type_name: str) -> str:
    """A definition from the message class's rosidl introspection (fields only)."""
    package, name = split_type_name(type_name)
    try:
        cls = getattr(importlib.import_module(f'{package}.msg'), name)
        fields = cls.get_fields_and_field_types()
    except (ImportError, AttributeError) as exc:
        raise SchemaError(f'no definition of {_full_name(package, name)}: no .msg file and '
                          f'no message class ({exc})') from None
    return ''.join(f'{_introspection_type(kind, package)} {field}\n'
                   for field, kind in fields.items())


@functools.lru_cache(maxsize=None)
def message_text(type_name: str) -> str:
    """The definition text of one type (no dependencies): the installed .msg file, the
    built-in text, or one generated from the message class."""
    package, name = split_type_name(type_name)
    full = _full_name(package, name)
    path = _msg_file(package, name, '.msg')
    if path is not None:
        return path.read_text(encoding='utf-8')
    if full in BUILTIN_DEFINITIONS:
        return BUILTIN_DEFINITIONS[full]
    return generated_definition(full)


def _field_types(text: str, package: str) -> list[str]:
    """The non-primitive field types of a definition, as 'pkg/msg/Type', in order."""
    out = []
    for raw in text.splitlines():
        line = raw.split('#', 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        if len(parts) < 2:
            continue
        kind = re.sub(r'\[.*?\]$', '', parts[0])
        kind = re.sub(r'<=\d+$', '', kind)
        if kind in _PRIMITIVES:
            continue  # primitives, and every constant ('int8 OK=0')
        if kind == 'Header':
            kind = 'std_msgs/Header'
        pkg, _, short = kind.rpartition('/')
        out.append(_full_name(pkg or package, short))
    return out


def dependencies(type_name: str) -> list[str]:
    """Every type ``type_name`` uses, transitively, each once, depth-first (rosbag2's order)."""
    order: list[str] = []

    def visit(name: str) -> None:
        package, _ = split_type_name(name)
        for dep in _field_types(message_text(name), package):
            if dep not in order and dep != type_name:
                order.append(dep)
                visit(dep)

    visit(type_name)
    return order


@functools.lru_cache(maxsize=None)
def message_schema(type_name: str) -> str:
    """The ``ros2msg`` schema text of ``type_name`` ('pkg/msg/Type') with its dependencies."""
    package, name = split_type_name(type_name)
    full = _full_name(package, name)
    text = message_text(full)
    for dep in dependencies(full):
        dep_package, dep_name = split_type_name(dep)
        text = (text.rstrip('\n') + '\n' + SEPARATOR + '\n' + f'MSG: {dep_package}/{dep_name}\n'
                + message_text(dep))
    return text


@functools.lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """The type's ``RIHS01_...`` hash from its installed type description, or '' if none."""
    package, name = split_type_name(type_name)
    path = _msg_file(package, name, '.json')
    if path is None:
        return ''
    try:
        data = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError):
        return ''
    full = _full_name(package, name)
    for entry in data.get('type_hashes', []):
        if entry.get('type_name') == full:
            return str(entry.get('hash_string', ''))
    return ''


def message_class(type_name: str):
    """The Python class of ``pkg/msg/Type`` (ImportError / AttributeError when not installed)."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)
