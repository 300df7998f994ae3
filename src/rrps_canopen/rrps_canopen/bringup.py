"""Bringing a bus' drives up: :func:`wait_for_drives` (boot-up, heartbeat or SDO answer within
``bus.boot_timeout``), :func:`check` (each drive against its EDS and the YAML's modes and homing
methods, every problem one sentence naming the drive and the object) and :func:`configure`
(heartbeat, homing method, PDOs, :data:`OPTIONAL_OBJECTS`). See docs/connecting-a-robot.md.
Pure Python (canopen), no ROS import.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

from canopen.sdo import SdoCommunicationError

from rrps_canopen.cia402 import Mode
from rrps_canopen.drive import NO_OBJECT, ConfigureError, RemoteDrive, mode_text, object_text
from rrps_canopen.pdo_mapping import map_pdos
from rrps_description.bus import HOMING_ABSOLUTE

__all__ = ['wait_for_drives', 'check', 'configure', 'reconfigure', 'fail', 'grouped', 'REQUIRED_OBJECTS',
           'OPTIONAL_OBJECTS']

#: The objects a drive's EDS must have, per mode (index: name).
REQUIRED_OBJECTS = {
    Mode.CYCLIC_SYNCHRONOUS_POSITION: (0x6040, 0x6041, 0x6060, 0x6064, 0x607A, 0x606C, 0x6077, 0x6076),
    Mode.CYCLIC_SYNCHRONOUS_TORQUE: (0x6040, 0x6041, 0x6060, 0x6064, 0x6071, 0x606C, 0x6077, 0x6076),
}
#: The optional objects configure writes: (index, the YAML keys that ask for it, what the drive
#: does when it is not written).
OPTIONAL_OBJECTS = (
    (0x605A, (), 'its own quick-stop reaction applies (the backend asks for "stop, then hold")'),
    (0x6065, ('following_error',), 'its own following-error window applies'),
    (0x6066, ('following_error_time',), 'its own following-error time out applies'),
    (0x607D, ('min_position', 'max_position'), 'it has no software position limits of its own (the backend '
                                               'still refuses commands outside them)'),
    (0x60C2, (), 'it takes its own interpolation period (the SYNC period is the backend\'s)'),
    (0x6099, ('homing_speed',), 'it homes at its own speed'),
)
_ASKING = {index: keys for index, keys, _ in OPTIONAL_OBJECTS}
_WITHOUT = {index: text for index, _, text in OPTIONAL_OBJECTS}
#: [s] between two SDO requests to a drive that does not answer yet.
POLL_PERIOD = 0.1


def grouped(items: list[tuple[RemoteDrive, str]]) -> str:
    """Sentences ``template`` naming their drives (``{drive}``), one per template: the same problem
    of several drives is one sentence naming them all."""
    groups: dict[str, list[str]] = {}
    for d, template in items:
        groups.setdefault(template, []).append(str(d))
    return '; '.join(template.format(drive=', '.join(names)) for template, names in groups.items())


def fail(problems: list[tuple[RemoteDrive, str]]) -> None:
    """ConfigureError with every problem, one sentence each (none: nothing)."""
    if problems:
        raise ConfigureError(grouped(problems))


def wait_for_drives(drives: list[RemoteDrive], timeout: float) -> None:
    """Return once every drive was heard (boot-up, heartbeat) or answered an SDO request; a
    ConfigureError naming those that did neither within ``timeout`` s."""
    deadline = time.monotonic() + timeout
    waiting = list(drives)
    while True:
        unheard = []
        for d in waiting:
            with d.lock:
                if d.data.heartbeat_time is None:
                    unheard.append(d)
        answering = _answering(unheard) if unheard else []
        waiting = [d for d in unheard if d not in answering]
        if not waiting:
            return
        if time.monotonic() > deadline:
            fail([(d, '{drive}: no boot-up message, heartbeat or SDO answer within bus.boot_timeout '
                      f'{timeout:g} s: wrong node id, the drive is off, or the bus is not connected') for d in waiting])
        time.sleep(POLL_PERIOD)


def _answering(drives: list[RemoteDrive]) -> list[RemoteDrive]:
    """The drives that answer one SDO request (their device type), asked all at once."""
    def answers(d: RemoteDrive) -> bool:
        retries, d.node.sdo.MAX_RETRIES = d.node.sdo.MAX_RETRIES, 1
        try:
            d.node.sdo.upload(0x1000, 0)
        except SdoCommunicationError:
            return False
        except Exception:  # noqa: BLE001 - any answer, even an abort, says the drive is there
            return True
        finally:
            d.node.sdo.MAX_RETRIES = retries
        return True
    with ThreadPoolExecutor(max_workers=len(drives)) as pool:
        return [d for d, ok in zip(drives, pool.map(answers, drives)) if ok]


def check(d: RemoteDrive, *, homes: bool) -> list[tuple[RemoteDrive, str]]:
    """The problems of drive ``d`` (see the module docstring); ``homes``: it will home. What
    could not be checked is in ``d.notes``."""
    d.notes = []
    od = d.node.object_dictionary
    missing = [object_text(i) for i in REQUIRED_OBJECTS[d.mode] if i not in od]
    if missing:
        return [(d, f'{{drive}}: its EDS {d.eds} lacks {", ".join(missing)}: not a CiA 402 drive EDS for this mode')]
    device_type = d.read_object(0x1000)
    vendor, product = d.read_object(0x1018, 1), d.read_object(0x1018, 2)
    info = od.device_information
    expected = (od[0x1000].default, info.vendor_number, info.product_number)
    if (device_type, vendor, product) != expected:
        return [(d, f'{{drive}}: the drive reports device type 0x{device_type:08X}, vendor 0x{vendor:08X}, product '
                    f'0x{product:08X} but its EDS {d.eds} describes 0x{expected[0]:08X}, 0x{expected[1] or 0:08X}, '
                    f'0x{expected[2] or 0:08X}: wrong EDS or wrong node id')]
    if device_type & 0xFFFF != 402:
        return [(d, f'{{drive}}: device type 0x{device_type:08X} is not a CiA 402 drive')]
    problems = []
    modes = d.probe(0x6502, 0)
    needed = [int(d.mode)] + ([int(Mode.HOMING)] if homes else [])
    if modes is None:
        d.notes.append(f'{{drive}}: no {object_text(0x6502)}: the modes are not checked before they are used')
    else:
        supported = [m for m in range(1, 11) if modes >> (m - 1) & 1]
        problems += [(d, f'{mode_text(m)} not supported by {{drive}}; supported: modes '
                         f'{", ".join(map(str, supported)) or "none"} ({object_text(0x6502)} 0x{modes:08X})')
                     for m in needed if m not in supported]
    method = d.config.homing
    if homes:
        methods = _homing_methods(d)
        if methods is None:
            d.notes.append(f'{{drive}}: no {object_text(0x60E3)}: homing method {method} is not checked before '
                           'it is written')
        elif method not in methods:
            problems.append((d, f'homing method {method} not supported by {{drive}}; supported: '
                                f'{", ".join(map(str, methods)) or "none"} ({object_text(0x60E3)})'))
    return problems


def _homing_methods(d: RemoteDrive) -> list[int] | None:
    count = d.probe(0x60E3, 0)
    if count is None:
        return None
    methods = [d.probe(0x60E3, k, signed=True) for k in range(1, count + 1)]
    return [m for m in methods if m is not None]


def _optional(d: RemoteDrive, index: int, subindex: int | None, value: int) -> bool:
    """Write an optional object (docs/connecting-a-robot.md, 'Optional objects'); whether it was written."""
    asked = [k for k in _ASKING[index] if k in d.config.given]
    if not asked and index not in d.node.object_dictionary:
        d.notes.append(f'{{drive}}: {object_text(index)} not written (not in the EDS): {_WITHOUT[index]}')
        return False
    try:
        d.write_object(index, subindex, value)
    except ConfigureError as exc:
        if asked or exc.abort_code is None:
            keys = ', '.join(f'bus.drives.{d.name}.{k}' for k in asked)
            raise ConfigureError(f'{exc}' + (f' ({keys} asks for it)' if keys else '')) from None
        what = 'has no such object' if exc.abort_code in NO_OBJECT else f'refuses {value}: {exc.reason}'
        d.notes.append(f'{{drive}}: {object_text(index, subindex)} not written (the drive {what}): {_WITHOUT[index]}')
        return False
    return True


def configure(d: RemoteDrive, *, heartbeat_period: float, sync_period: float) -> None:
    """Set the drive up (PRE-OPERATIONAL, by SDO); it stays in its power state. What it skipped
    is in ``d.notes``."""
    c, s = d.config, d.scale
    d.node.nmt.send_command(0x80)
    d.write_object(0x1017, None, max(1, round(heartbeat_period * 1000)))
    _optional(d, 0x605A, None, 6)  # quick stop: stop, then stay in QUICK STOP ACTIVE, holding
    _optional(d, 0x6065, None, s.distance_counts(c.following_error))
    _optional(d, 0x6066, None, max(1, round(c.following_error_time * 1000)))
    lo, hi = s.limit_counts()
    if _optional(d, 0x607D, 1, lo):
        _optional(d, 0x607D, 2, hi)
    if _optional(d, 0x60C2, 1, max(1, round(sync_period * 1000))):
        _optional(d, 0x60C2, 2, -3)
    if c.homing != HOMING_ABSOLUTE:
        try:
            d.write_object(0x6098, None, c.homing)
        except ConfigureError as exc:
            if exc.abort_code is None:
                raise
            raise ConfigureError(f'homing method {c.homing} refused by {d} ({object_text(0x6098)}: {exc.reason}); '
                                 f'it does not list its methods ({object_text(0x60E3)})') from None
        d.write_object(0x607C, None, s.counts(c.home_position))
        _optional(d, 0x6099, 1, abs(s.counts_per_second(c.homing_speed)))
    if c.rated_force is not None:
        d.write_object(0x6076, None, round(c.rated_force * 1000.0))  # N -> mN
    s.rated_force = d.read_object(0x6076) / 1000.0  # mN -> N
    d.notes += map_pdos(d)
    d.take_process_data()


def reconfigure(d: RemoteDrive, *, heartbeat_period: float, sync_period: float) -> None:
    """Set a rebooted drive up again (:func:`configure`) and start it (OPERATIONAL); it stays in
    the power state it booted in (disabled), and its digital outputs as it restarted them."""
    d.notes = []
    configure(d, heartbeat_period=heartbeat_period, sync_period=sync_period)
    if d.digital_io:  # its outputs restarted de-energised: never switch them back by itself
        d.outputs = d.read_object(0x60FE, 1)
    d.start()
