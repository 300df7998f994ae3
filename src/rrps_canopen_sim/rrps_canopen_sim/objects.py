"""The object dictionary of a simulated drive (:func:`device_dictionary`): its EDS's, changed by its
:class:`~rrps_canopen_sim.behaviour.DriveBehaviour` (homing methods, modes, absent objects, the
``vendor`` PDO layout with one more RPDO and TPDO than the EDS lists). Pure Python (canopen)."""

from __future__ import annotations

import canopen
from canopen.objectdictionary import ODRecord, ODVariable
from canopen.objectdictionary.datatypes import INTEGER8, UNSIGNED8, UNSIGNED32

from rrps_canopen_sim.behaviour import DriveBehaviour

__all__ = ['device_dictionary', 'VENDOR_RPDOS', 'VENDOR_TPDOS', 'SUPPORTED_HOMING_METHODS']

#: CiA 402 0x60E3: supported homing methods (sub-index 0: how many).
SUPPORTED_HOMING_METHODS = 0x60E3
#: The ``vendor`` layout at power-on: per PDO number, (COB-ID base, transmission type, mapped
#: objects as CiA 301 mapping entries: index << 16 | sub-index << 8 | bits).
VENDOR_RPDOS = {1: (0x200, 255, (0x60400010,)), 2: (0x300, 1, (0x607A0020,)), 3: (0x400, 255, (0x60600008,))}
VENDOR_TPDOS = {1: (0x180, 255, (0x60410010, 0x60610008)), 2: (0x280, 1, (0x60640020, 0x606C0020)),
                3: (0x380, 1, (0x60F40020,)), 4: (0x480, 1, (0x60410010, 0x60640020))}
#: Mapping entries per PDO of the records this module adds.
_ENTRIES = 4


def _variable(index: int, subindex: int, name: str, data_type: int, access: str, default: int) -> ODVariable:
    var = ODVariable(name, index, subindex)
    var.data_type, var.access_type, var.default = data_type, access, default
    return var


def _record(index: int, name: str, members: list[ODVariable]) -> ODRecord:
    record = ODRecord(name, index)
    for var in members:
        record.add_member(var)
    return record


def _pdo_records(od: canopen.ObjectDictionary, kind: str, number: int, node_id: int,
                 layout: tuple[int, int, tuple[int, ...]]) -> None:
    """One PDO's communication and mapping records (``kind`` 'Receive' or 'Transmit'), added or
    given the layout's values as their power-on defaults."""
    com, mapping = (0x1400, 0x1600) if kind == 'Receive' else (0x1800, 0x1A00)
    com, mapping = com + number - 1, mapping + number - 1
    cob_base, trans_type, entries = layout
    if com not in od:
        od.add_object(_record(com, f'{kind} PDO {number} communication parameter', [
            _variable(com, 0, 'Highest sub-index supported', UNSIGNED8, 'const', 2),
            _variable(com, 1, 'COB-ID', UNSIGNED32, 'rw', 0),
            _variable(com, 2, 'Transmission type', UNSIGNED8, 'rw', 0)]))
        od.add_object(_record(mapping, f'{kind} PDO {number} mapping parameter', [
            _variable(mapping, 0, 'Number of mapped objects', UNSIGNED8, 'rw', 0),
            *(_variable(mapping, k, f'Mapped object {k}', UNSIGNED32, 'rw', 0) for k in range(1, _ENTRIES + 1))]))
    od[com][1].default = cob_base + node_id
    od[com][2].default = trans_type
    od[mapping][0].default = len(entries)
    for k in od[mapping]:
        if k:
            od[mapping][k].default = entries[k - 1] if k <= len(entries) else 0


def device_dictionary(eds: str, node_id: int, behaviour: DriveBehaviour | None) -> canopen.ObjectDictionary:
    """The object dictionary of a simulated device of ``eds`` behaving as ``behaviour``."""
    od = canopen.import_od(eds, node_id)
    if behaviour is None:
        return od
    if 0x6502 in od:
        od[0x6502].default = behaviour.supported_modes()
    if SUPPORTED_HOMING_METHODS in od:
        del od[SUPPORTED_HOMING_METHODS]
        methods = behaviour.homing_methods
        od.add_object(_record(SUPPORTED_HOMING_METHODS, 'Supported homing methods', [
            _variable(SUPPORTED_HOMING_METHODS, 0, 'Number of entries', UNSIGNED8, 'ro', len(methods)),
            *(_variable(SUPPORTED_HOMING_METHODS, k, f'Homing method {k}', INTEGER8, 'ro', m)
              for k, m in enumerate(methods, 1))]))
    if behaviour.pdo_layout == 'vendor':
        for number, layout in VENDOR_RPDOS.items():
            _pdo_records(od, 'Receive', number, node_id, layout)
        for number, layout in VENDOR_TPDOS.items():
            _pdo_records(od, 'Transmit', number, node_id, layout)
    for index in behaviour.absent:
        if index in od:
            del od[index]
    return od
