"""How a simulated drive behaves where CiA 301/402 leave a vendor the choice: its timing, its
homing methods and limit switches, its object dictionary and its power-on PDO mapping.

A drive of the simulator is by default the drive of the shipped EDS, answering at once.
:class:`DriveBehaviour` changes that, one option at a time, so that tests can meet the drives
the stack has never seen: a drive that shows a new mode in 0x6061 some time after the request, boots
late, homes only by some methods, has no limit switches, enforces its software position limits
before it is homed, lacks or refuses an optional object, powers on with another PDO mapping or
keeps a fixed one, loses an SDO request now and then. :func:`behaviours` reads them from a
mapping (``rrps-drive-sim --behaviour JSON``): options for every drive, or per drive under its
name. Pure Python, no ROS import.
"""

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
    """One simulated drive's choices (see the module docstring).

    ``mode_delay`` [s]: 0x6061 shows a mode written to 0x6060 this long after the write (the
    drive runs the old mode meanwhile). ``boot_delay`` [s]: the drive is off until the first SDO
    request to it, and boots this long after it (None: it boots when the simulator starts).
    ``homing_methods``: what 0x60E3 lists and 0x6098 accepts; ``modes``: the modes of operation
    0x6502 lists and 0x6060 accepts. ``limit_switches``: the axis has its limit switches at the
    stroke's ends (the negative one at the end where the count is lowest). ``index_pitch`` [m]:
    the encoder's index pulses, half a pitch inside each end and a pitch apart.
    ``limits_before_homing``: the software position limits (0x607D) act in cyclic synchronous
    position mode before the drive is homed. ``refuse``: objects whose writes the drive refuses
    (SDO abort "value range exceeded"); ``absent``: objects the drive does not have (abort "object
    does not exist"). ``pdo_layout``: one of :data:`PDO_LAYOUTS`; ``fixed_pdos``: the drive takes
    PDO mapping writes but keeps its power-on mapping. ``sdo_loss``: every n-th SDO request to the
    drive is lost (0: none).
    """

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
