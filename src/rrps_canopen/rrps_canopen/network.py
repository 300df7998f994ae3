"""Opening a robot's CAN bus with canopen and python-can (``bus.interface``, ``bus.channel``,
``bus.options`` as python-can names them; ``RRPS_CAN_CHANNEL`` and ``RRPS_CAN_PORT`` override
the channel and the loopback port), and finding its EDS files. Pure Python, no ROS import."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import can
import canopen

from rrps_description.bus import BusConfig

__all__ = ['open_network', 'resolve_eds', 'shipped_eds', 'bus_arguments']


def shipped_eds() -> list[str]:
    """The EDS files shipped with this package."""
    return sorted(p.name for p in (resources.files('rrps_canopen') / 'eds').iterdir() if p.name.endswith('.eds'))


def resolve_eds(name: str, base_dir: str = '') -> str:
    """The path of an EDS: absolute, relative to the robot YAML's folder, or shipped by name;
    FileNotFoundError naming where it looked."""
    candidates = [Path(name)] if Path(name).is_absolute() else [Path(base_dir or '.') / name]
    candidates.append(Path(str(resources.files('rrps_canopen') / 'eds' / name)))
    for path in candidates:
        if path.is_file():
            return str(path)
    raise FileNotFoundError(f'EDS {name!r} not found (looked in {", ".join(str(c) for c in candidates)}; '
                            f'shipped: {", ".join(shipped_eds())})')


def bus_arguments(config: BusConfig) -> dict:
    """The keyword arguments of ``can.Bus`` for this bus (with the environment's overrides)."""
    kwargs = {'interface': config.interface, 'channel': os.environ.get('RRPS_CAN_CHANNEL', config.channel),
              'bitrate': config.bitrate, **config.options}
    if config.interface == 'rrps_loopback':
        kwargs.pop('bitrate')
        if 'RRPS_CAN_PORT' in os.environ:
            kwargs['port'] = int(os.environ['RRPS_CAN_PORT'])
    return kwargs


def open_network(config: BusConfig, listeners: tuple[can.Listener, ...] = ()) -> canopen.Network:
    """A connected canopen Network on the bus (``listeners`` also get every frame, error frames
    included); can.CanError when the adapter cannot be opened."""
    network = canopen.Network()
    network.listeners.extend(listeners)
    network.connect(**bus_arguments(config))
    return network
