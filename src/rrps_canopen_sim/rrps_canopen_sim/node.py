"""A simulated CANopen device on canopen's ``LocalNode``: NMT, boot-up, heartbeat, PDOs on SYNC.

:class:`SimulatedNode` is what the drive and the I/O module share: the object dictionary from
its EDS, NMT, heartbeat, PDOs, EMCY, the faults ``silent`` and ``reboot``, a late power-on
(:meth:`SimulatedNode.power_on_when_asked`) and lost SDO requests. Pure Python."""

from __future__ import annotations

import logging
import threading
from typing import Any

import canopen
from canopen.pdo import PdoMap
from canopen.sdo import SdoAbortedError

__all__ = ['SimulatedNode']

log = logging.getLogger(__name__)

_OPERATIONAL, _RESET_NODE, _RESET_COMMUNICATION = 1, 0x81, 0x82
_ASYNC = 254  # transmission types >= this one: event driven


class SimulatedNode:
    """A CANopen device on ``network`` at ``node_id`` with the object dictionary of ``eds``.

    Subclasses keep their process values in attributes: :meth:`process_value` returns the value
    of an object they own (None: the stored one), :meth:`on_write` receives every write (SDO or
    RPDO), :meth:`on_reset` restores their power-on state.
    """

    def __init__(self, network: canopen.Network, node_id: int, eds: str,
                 object_dictionary: canopen.ObjectDictionary | None = None, *, sdo_loss: int = 0):
        self.network, self.node_id, self.eds = network, node_id, eds
        self.node = canopen.LocalNode(node_id, object_dictionary or eds)
        self.node.add_read_callback(self._on_read)
        self.node.add_write_callback(self._on_write)
        network.add_node(self.node)
        network.unsubscribe(self.node.sdo.rx_cobid, self.node.sdo.on_request)
        network.subscribe(self.node.sdo.rx_cobid, self._on_sdo_request)
        network.subscribe(0, self._on_nmt)
        self.silent = False
        self.operational = False
        self.sdo_loss, self._sdo_requests = sdo_loss, 0
        self._boot_delay: float | None = None
        self._pending: list[PdoMap] = []
        self._sync_count = 0

    # --- the subclass' side ---

    def process_value(self, index: int, subindex: int) -> Any:
        """The live value of an object the device computes (statusword, position ...); None: stored."""
        return None

    def on_write(self, index: int, subindex: int, value: Any) -> None:
        """A write to the object dictionary (SDO or RPDO), decoded."""

    def on_reset(self) -> None:
        """Back to the power-on state (a reset node or a reboot)."""

    # --- object dictionary ---

    def _on_read(self, index: int, subindex: int, od) -> Any:
        return self.process_value(index, subindex)

    def _on_write(self, index: int, subindex: int, od, data: bytes) -> None:
        self.on_write(index, subindex, od.decode_raw(data))

    def value(self, index: int, subindex: int = 0, default: Any = None) -> Any:
        """The stored (or EDS default) value of an object; ``default`` when the device lacks it."""
        if index not in self.node.object_dictionary:
            return default
        obj = self.node.object_dictionary[index]
        var = obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[subindex]
        return var.decode_raw(self.node.get_data(index, subindex))

    def _on_sdo_request(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self.silent:
            if self._boot_delay is not None:  # asked while off: it powers on a while later
                delay, self._boot_delay = self._boot_delay, None
                threading.Timer(delay, self._power_on).start()
            return
        self._sdo_requests += 1
        if self.sdo_loss and self._sdo_requests % self.sdo_loss == 0:
            return  # lost on the way
        self.node.sdo.on_request(can_id, data, timestamp)

    # --- NMT ---

    def _on_nmt(self, can_id: int, data: bytes, timestamp: float) -> None:
        if len(data) < 2 or data[1] not in (0, self.node_id) or self.silent:
            return
        command = data[0]
        if command in (_RESET_NODE, _RESET_COMMUNICATION):
            self.boot(reset_application=command == _RESET_NODE)
        elif command == _OPERATIONAL:
            self._start_pdos()
        else:
            self.operational = False

    def boot(self, *, reset_application: bool = True) -> None:
        """Power-on or reset: object dictionary back to the EDS (all of it, or the communication
        area 0x1000-0x1FFF), boot-up message, PRE-OPERATIONAL, no heartbeat until 0x1017 is set."""
        self.operational = False
        self._pending.clear()
        self._unsubscribe_rpdos()
        if reset_application:
            self.node.data_store.clear()
            self.on_reset()
        else:
            for index in [i for i in self.node.data_store if 0x1000 <= i < 0x2000]:
                del self.node.data_store[index]
        self.node.nmt.stop_heartbeat()
        self.node.nmt.send_command(_RESET_NODE)    # state INITIALISING: the boot-up message
        self.node.nmt.send_command(0x80)           # PRE-OPERATIONAL: heartbeat per 0x1017

    def reboot(self) -> None:
        """The device restarts by itself (a power glitch): boots as at power-on."""
        self.silent = False
        self.boot(reset_application=True)

    def power_on_when_asked(self, delay: float, lock: threading.Lock) -> None:
        """The device is off (silent, no boot-up message) until the first SDO request to it, and
        boots ``delay`` s after that request (under ``lock``: the bus' SYNC handler's)."""
        self.node.nmt.stop_heartbeat()
        self.silent, self._boot_delay, self._power_lock = True, delay, lock

    def _power_on(self) -> None:
        with self._power_lock:
            self.reboot()

    def set_silent(self, silent: bool) -> None:
        """Stop answering anything (a cut link) or come back (the heartbeat resumes)."""
        if silent == self.silent:
            return
        self.silent = silent
        if silent:
            self.node.nmt.stop_heartbeat()
        else:
            self.node.nmt.start_heartbeat(self.value(0x1017))

    # --- PDOs ---

    def _unsubscribe_rpdos(self) -> None:
        for pdo in self.node.rpdo.map.values():
            if pdo.cob_id and pdo.on_message in self.network.subscribers.get(pdo.cob_id, ()):
                self.network.unsubscribe(pdo.cob_id, pdo.on_message)

    def _start_pdos(self) -> None:
        """OPERATIONAL: the PDOs as the object dictionary configures them now."""
        self._unsubscribe_rpdos()
        self.node.rpdo.read()
        self.node.tpdo.read()
        for pdo in self.node.rpdo.map.values():
            if pdo.enabled and not pdo.callbacks:
                pdo.add_callback(self._on_rpdo)
        self.operational = True

    def _on_rpdo(self, pdo: PdoMap) -> None:
        if not self.operational or self.silent:
            return
        if pdo.trans_type is not None and pdo.trans_type >= _ASYNC:
            self._apply(pdo)
        elif pdo not in self._pending:
            self._pending.append(pdo)

    def _apply(self, pdo: PdoMap) -> None:
        for var in pdo.map:
            if var.length:
                try:
                    self.node.set_data(var.index, var.subindex, var.get_data())
                except SdoAbortedError:
                    pass  # a value the device refuses: a PDO has no answer, it is ignored

    def pdo_states(self) -> dict[str, bool]:
        """{'RPDO1': enabled, ..., 'TPDO1': ...}: every PDO of the device as configured now."""
        states = {}
        for kind, base in (('RPDO', 0x1400), ('TPDO', 0x1800)):
            for number in range(1, 513):
                if base + number - 1 not in self.node.object_dictionary:
                    break
                cob_id = self.value(base + number - 1, 1)
                states[f'{kind}{number}'] = not cob_id & 0x80000000
        return states

    def take_rpdos(self) -> None:
        """At SYNC: the synchronous RPDOs received since the last one take effect."""
        pending, self._pending = self._pending, []
        for pdo in pending:
            self._apply(pdo)

    def send_tpdos(self) -> None:
        """At SYNC: the synchronous TPDOs due (every n-th SYNC for transmission type n)."""
        if not self.operational or self.silent:
            return
        self._sync_count += 1
        for pdo in self.node.tpdo.map.values():
            if pdo.enabled and pdo.trans_type and pdo.trans_type <= 240 and self._sync_count % pdo.trans_type == 0:
                self.send_tpdo(pdo)

    def send_tpdo(self, pdo: PdoMap) -> None:
        for var in pdo.map:
            if var.length:
                var.set_data(self.node.get_data(var.index, var.subindex))
        pdo.transmit()

    def emergency(self, code: int, register: int) -> None:
        """Send an EMCY (error code, error register)."""
        if not self.silent:
            self.node.emcy.send(code, register)
