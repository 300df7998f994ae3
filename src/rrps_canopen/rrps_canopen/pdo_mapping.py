"""A drive's PDOs as the backend uses them (:func:`map_pdos`), written, read back and compared; every
other PDO of the device disabled, whether its EDS lists it or not. TPDO2 (velocity, torque) comes
every :data:`SLOW_TPDO_EVERY` SYNCs in position mode. A drive that keeps its own mapping is refused
with both mappings; the layout: docs/connecting-a-robot.md, 'PDOs'. Pure Python (canopen)."""

from __future__ import annotations

from canopen.sdo import SdoAbortedError, SdoCommunicationError

from rrps_canopen.cia402 import Mode
from rrps_canopen.drive import ConfigureError, RemoteDrive

__all__ = ['map_pdos', 'SLOW_TPDO_EVERY', 'PDO_INVALID']

#: In position mode the drive's velocity and torque (TPDO2) go out every this many SYNCs (they
#: inform, they do not close a loop); in torque mode every SYNC (the force output's damping).
SLOW_TPDO_EVERY = 5
#: COB-ID bit 31: the PDO does not exist / is disabled (CiA 301).
PDO_INVALID = 0x80000000
#: The most PDOs of each kind CiA 301 allows.
_MAX_PDOS = 512
#: (name, communication object, mapping object) of each kind.
_KINDS = (('RPDO', 0x1400, 0x1600), ('TPDO', 0x1800, 0x1A00))


def _wanted(drive: RemoteDrive) -> tuple[list, list]:
    """The objects of each RPDO and TPDO the backend uses, in PDO order ((index, sub-index))."""
    second = 0x607A if drive.mode is Mode.CYCLIC_SYNCHRONOUS_POSITION else 0x6071
    rpdo = [[(0x6040, 0), (second, 0)]]
    tpdo = [[(0x6041, 0), (0x6064, 0)], [(0x606C, 0), (0x6077, 0)]]
    if drive.digital_io:
        rpdo.append([(0x60FE, 1)])
        tpdo.append([(0x60FD, 0)])
    return rpdo, tpdo


def _layout(enabled: bool, trans_type: int | None, entries: list[int]) -> str:
    if not enabled:
        return 'disabled'
    objects = ' + '.join(f'0x{e >> 16:04X}:{e >> 8 & 0xFF} ({e & 0xFF} bits)' for e in entries) or 'nothing'
    return f'{objects}, transmission type {trans_type}'


def _read_back(pdo) -> tuple[bool, int | None, list[int]]:
    cob_id = pdo.com_record[1].raw
    enabled = not cob_id & PDO_INVALID
    trans_type = pdo.com_record[2].raw if enabled else None
    count = pdo.map_array[0].raw
    return enabled, trans_type, [pdo.map_array[k].raw for k in range(1, count + 1)]


def map_pdos(drive: RemoteDrive) -> list[str]:
    """Write the drive's PDOs, disable the others, read them back and compare (see the module
    docstring); what was disabled beyond the EDS, as notes; ConfigureError naming the PDO."""
    node, notes = drive.node, []
    node.rpdo.read(from_od=True)
    node.tpdo.read(from_od=True)
    slow = SLOW_TPDO_EVERY if drive.mode is Mode.CYCLIC_SYNCHRONOUS_POSITION else 1
    written = {}
    for (kind, _, _), maps, wanted in zip(_KINDS, (node.rpdo, node.tpdo), _wanted(drive)):
        if len(maps.map) < len(wanted):
            raise ConfigureError(f'{drive}: its EDS {drive.eds} lists {len(maps.map)} {kind}s, the backend needs '
                                 f'{len(wanted)}')
        for number, pdo in maps.map.items():
            pdo.clear()
            objects = wanted[number - 1] if number <= len(wanted) else []
            for index, subindex in objects:
                pdo.add_variable(index, subindex)
            pdo.trans_type = slow if kind == 'TPDO' and number == 2 else 1
            pdo.enabled = bool(objects)
            if pdo.enabled and not pdo.cob_id:
                pdo.cob_id = pdo.predefined_cob_id
            written[f'{kind}{number}'] = (pdo, (pdo.enabled, pdo.trans_type if pdo.enabled else None,
                                                [v.index << 16 | v.subindex << 8 | v.length for v in pdo.map]))
    try:
        node.rpdo.save()
        node.tpdo.save()
        notes += _disable_unlisted(drive)
        for name, (pdo, want) in written.items():
            got = _read_back(pdo)
            if got != want:
                raise ConfigureError(
                    f'{drive}: {name} reads back as {_layout(*got)}, written as {_layout(*want)}: the drive does not '
                    f'take this mapping (a fixed PDO mapping, or an EDS that is not its own: {drive.eds})')
    except SdoCommunicationError:
        raise ConfigureError(f'{drive}: no answer while mapping its PDOs (SDO timeout)') from None
    except SdoAbortedError as exc:
        raise ConfigureError(f'{drive}: its PDO mapping was refused: {exc}') from None
    for pdo in node.tpdo.map.values():
        if pdo.enabled and drive.on_tpdo not in pdo.callbacks:
            pdo.add_callback(drive.on_tpdo)
    return notes


def _disable_unlisted(drive: RemoteDrive) -> list[str]:
    """Disable the device's PDOs its EDS does not list (read until one does not exist)."""
    notes = []
    for (kind, com, _), maps in zip(_KINDS, (drive.node.rpdo, drive.node.tpdo)):
        for number in range(len(maps.map) + 1, _MAX_PDOS + 1):
            index = com + number - 1
            cob_id = drive.probe(index, 1)
            if cob_id is None:
                break
            if not cob_id & PDO_INVALID:
                drive.node.sdo.download(index, 1, (cob_id | PDO_INVALID).to_bytes(4, 'little'))
                if not drive.probe(index, 1) & PDO_INVALID:
                    raise ConfigureError(f'{drive}: {kind}{number} (0x{index:04X}, not in its EDS) stays enabled '
                                         'after writing its COB-ID invalid')
                notes.append(f'{{drive}}: {kind}{number} (0x{index:04X}, not in the EDS) was enabled: disabled')
    return notes
