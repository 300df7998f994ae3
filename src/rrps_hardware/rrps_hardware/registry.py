"""The driver's hardware: the interface (:mod:`.interface`) and the registry of its implementations,
by name in the ``rrps.hardware`` entry-point group (``rrps.master_hardware`` for
:func:`master_hardware_class`)::

    robot = hardware_class('simulated')()

Each implementation owns its ``PARAMETERS``, declared by its host (:func:`hardware_parameters`).
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Callable

from rrps_hardware.interface import SystemInterface
from rrps_hardware.master import MasterInterface
from rrps_runtime.parameter_schema import NodeParameters

__all__ = ['GROUP', 'MASTER_GROUP', 'registered_hardware', 'registered_master_hardware', 'hardware_class',
           'master_hardware_class', 'hardware_parameters']

GROUP = 'rrps.hardware'
MASTER_GROUP = 'rrps.master_hardware'


def _entry_points(group: str) -> dict[str, Callable[[], type]]:
    return {ep.name: ep.load for ep in sorted(entry_points(group=group), key=lambda ep: ep.name)}


def registered_hardware() -> dict[str, Callable[[], type[SystemInterface]]]:
    """{name: loader of the class} of every installed implementation, sorted by name."""
    return _entry_points(GROUP)


def registered_master_hardware() -> dict[str, Callable[[], type[MasterInterface]]]:
    """{name: loader of the class} of every installed master hardware, sorted by name."""
    return _entry_points(MASTER_GROUP)


def _registered(name: str, known: dict, base: type) -> type:
    if name not in known:
        raise ValueError(f'unknown hardware {name!r}; known: {", ".join(sorted(known)) or "none"}')
    cls = known[name]()
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise ValueError(f'hardware {name!r} is {cls!r}, not a {base.__name__}')
    return cls


def hardware_class(name: str) -> type[SystemInterface]:
    """The implementation registered as ``name``; ValueError naming the known ones."""
    return _registered(name, registered_hardware(), SystemInterface)


def master_hardware_class(name: str) -> type[MasterInterface]:
    """The master robot's hardware registered as ``name``; ValueError naming the known ones."""
    return _registered(name, registered_master_hardware(), MasterInterface)


def hardware_parameters(node: NodeParameters, cls: type[SystemInterface] | type[MasterInterface]) -> NodeParameters:
    """The parameters the implementation ``cls`` owns, as the host ``node`` declares them (under the
    implementation's package); ValueError when one of them has the name of one of the host's own."""
    clash = sorted({p.name for p in node} & {p.name for p in cls.PARAMETERS})
    if clash:
        raise ValueError(f'{cls.__name__} declares {", ".join(clash)}, parameters of {node.node} itself')
    return NodeParameters(node.node, cls.__module__.split('.')[0], cls.PARAMETERS)
