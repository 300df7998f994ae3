"""The driver's hardware: the interface (:mod:`.interface`) and the registry of its implementations.

An implementation is registered by name in the ``rrps.hardware`` entry-point group of its
package's setup.py (``simulated = rrps_sim.hardware.simulated:SimulatedRobot``); the driver
node hosts the one its ``hardware`` parameter names::

    robot = hardware_class('simulated')()
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Callable

from rrps_sim.hardware.interface import SystemInterface

__all__ = ['GROUP', 'registered_hardware', 'hardware_class']

GROUP = 'rrps.hardware'


def registered_hardware() -> dict[str, Callable[[], type[SystemInterface]]]:
    """{name: loader of the class} of every installed implementation, sorted by name."""
    return {ep.name: ep.load for ep in sorted(entry_points(group=GROUP), key=lambda ep: ep.name)}


def hardware_class(name: str) -> type[SystemInterface]:
    """The implementation registered as ``name``; ValueError naming the known ones."""
    known = registered_hardware()
    if name not in known:
        raise ValueError(f'unknown hardware {name!r}; known: {", ".join(sorted(known)) or "none"}')
    cls = known[name]()
    if not (isinstance(cls, type) and issubclass(cls, SystemInterface)):
        raise ValueError(f'hardware {name!r} is {cls!r}, not a SystemInterface')
    return cls
