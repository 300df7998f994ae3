"""How a simulated drive behaves where CiA 301/402 leave a vendor the choice (timing, homing, object
dictionary, PDO mapping), so that tests meet drives the stack has never seen. :func:`behaviours`
reads them from ``rrps-drive-sim --behaviour JSON``: options for every drive, or per drive under
its name. Pure Python, no ROS import."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping

__all__ = ['DriveBehaviour', 'behaviours', 'PDO_LAYOUTS']

#: ``eds``: the power-on PDO mapping of the EDS; ``vendor``: another one, with an RPDO and a TPDO
#: more than the EDS lists, enabled (simulator.objects).
PDO_LAYOUTS = ('eds', 'vendor')


@dataclass(frozen=True)
class DriveBehaviour:
    """One simulated drive's choices; the default is the shipped EDS's drive, answering at once.

    ``mode_delay`` [s] until 0x6061 shows a mode written to 0x6060; ``boot_delay`` [s] after the first
    SDO request (None: at start); ``homing_methods`` (0x60E3, 0x6098), ``modes`` (0x6502, 0x6060);
    ``limit_switches`` at the stroke's ends; ``index_pitch`` [m]; ``limits_before_homing`` (0x607D in
    CSP); objects whose writes it refuses (``refuse``) or it lacks (``absent``); ``pdo_layout`` (one of
    :data:`PDO_LAYOUTS`), ``fixed_pdos`` (mapping writes ignored); ``sdo_loss``: every n-th SDO lost."""

    mode_delay: float = 0.0
    boot_delay: float | None = None
    homing_methods: tuple[int, ...] = (1, 2, 17, 18, 35, 37)
    modes: tuple[int, ...] = (6, 8, 10)
    limit_switches: bool = True
    index_pitch: float = 0.002
    limits_before_homing: bool = False
    refuse: tuple[int, ...] = ()
    absent: tuple[int, ...] = ()
    pdo_layout: str = 'eds'
    fixed_pdos: bool = False
    sdo_loss: int = 0

    def __post_init__(self):
        if self.mode_delay < 0 or (self.boot_delay is not None and self.boot_delay < 0):
            raise ValueError(f'delays must be >= 0 s, got {self.mode_delay}, {self.boot_delay}')
        if self.pdo_layout not in PDO_LAYOUTS:
            raise ValueError(f'pdo_layout must be one of {PDO_LAYOUTS}, got {self.pdo_layout!r}')
        if self.index_pitch <= 0 or self.sdo_loss < 0:
            raise ValueError('index_pitch must be > 0 m and sdo_loss >= 0')
        if not all(-128 <= m <= 127 for m in self.homing_methods) or not all(1 <= m <= 10 for m in self.modes):
            raise ValueError(f'homing methods are INTEGER8 and modes 1..10, got {self.homing_methods}, {self.modes}')

    def supported_modes(self) -> int:
        """0x6502: bit m - 1 for mode of operation m (CiA 402)."""
        return sum(1 << (m - 1) for m in set(self.modes))


_FIELDS = {f.name for f in dataclasses.fields(DriveBehaviour)}
_INDEX_LISTS = ('refuse', 'absent')


def _index(value: Any) -> int:
    return int(value, 16) if isinstance(value, str) else int(value)


def _options(spec: Mapping[str, Any], where: str) -> dict:
    unknown = sorted(set(spec) - _FIELDS)
    if unknown:
        raise ValueError(f'{where}: unknown drive behaviour {unknown}; known: {sorted(_FIELDS)}')
    options = dict(spec)
    for key in _INDEX_LISTS:
        if key in options:
            options[key] = tuple(_index(v) for v in options[key])
    for key in ('homing_methods', 'modes'):
        if key in options:
            options[key] = tuple(int(v) for v in options[key])
    return options


def behaviours(spec: Mapping[str, Any] | None, names) -> dict[str, DriveBehaviour]:
    """{drive: behaviour}: the options of ``spec`` for every drive, those under a drive's name
    for that one (ValueError naming an unknown option or drive)."""
    spec = dict(spec or {})
    names = list(names)
    per_drive = {name: spec.pop(name) for name in names if name in spec}
    common = _options({k: v for k, v in spec.items()}, 'behaviour')
    result = {}
    for name in names:
        own = per_drive.get(name, {})
        if not isinstance(own, Mapping):
            raise ValueError(f'behaviour.{name}: expected a mapping of options, got {own!r}')
        result[name] = DriveBehaviour(**{**common, **_options(own, f'behaviour.{name}')})
    return result
