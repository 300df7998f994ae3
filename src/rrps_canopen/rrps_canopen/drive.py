"""One CiA 402 drive as the backend sees it: :class:`RemoteDrive` wraps canopen's ``RemoteNode``
with SDOs sent again when unanswered (``bus.sdo_retries``) and errors naming the drive and the
object; its TPDOs, heartbeat and EMCYs update :class:`ProcessData` from canopen's receive thread.
Pure Python (canopen), no ROS import."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import canopen
from canopen.sdo import SdoAbortedError, SdoCommunicationError

from rrps_canopen.cia402 import Mode, State, state_of
from rrps_canopen.units import AxisScale
from rrps_description.bus import HOMING_ABSOLUTE, DriveConfig

__all__ = ['ConfigureError', 'RemoteDrive', 'ProcessData', 'OBJECT_NAMES', 'MODE_NAMES', 'NO_OBJECT', 'BOOT_UP',
           'object_text', 'mode_text', 'keep_word']

#: The objects the backend reads or writes, in words (CiA 301 / 402 names).
OBJECT_NAMES = {
    0x1000: 'device type', 0x1017: 'producer heartbeat time', 0x1018: 'identity', 0x6040: 'controlword',
    0x6041: 'statusword', 0x605A: 'quick stop option code', 0x6060: 'modes of operation',
    0x6061: 'modes of operation display', 0x6064: 'position actual value', 0x6065: 'following error window',
    0x6066: 'following error time out', 0x606C: 'velocity actual value', 0x6071: 'target torque',
    0x6076: 'motor rated torque', 0x6077: 'torque actual value', 0x607A: 'target position', 0x607C: 'home offset',
    0x607D: 'software position limit', 0x6098: 'homing method', 0x6099: 'homing speeds',
    0x60C2: 'interpolation time period', 0x60E3: 'supported homing methods', 0x60FD: 'digital inputs',
    0x60FE: 'digital outputs', 0x6502: 'supported drive modes',
}
#: The modes of operation in words.
MODE_NAMES = {int(Mode.HOMING): 'homing', int(Mode.CYCLIC_SYNCHRONOUS_POSITION): 'cyclic synchronous position',
              int(Mode.CYCLIC_SYNCHRONOUS_TORQUE): 'cyclic synchronous torque'}
#: SDO abort codes (CiA 301) that say the device has no such object or sub-index.
NO_OBJECT = (0x06020000, 0x06090011)
#: Heartbeat state of a boot-up message.
BOOT_UP = 0


class ConfigureError(Exception):
    """A drive or its EDS is not what the robot YAML says (the message names the drive);
    ``abort_code`` and ``reason``: when the drive refused an SDO request, its abort code and its
    meaning (CiA 301)."""

    def __init__(self, message: str, abort_code: int | None = None, reason: str = ''):
        super().__init__(message)
        self.abort_code, self.reason = abort_code, reason


def mode_text(mode: int) -> str:
    """``homing mode``, ``no mode`` (0), ``mode 3``."""
    return f'{MODE_NAMES[mode]} mode' if mode in MODE_NAMES else 'no mode' if mode == 0 else f'mode {mode}'


def object_text(index: int, subindex: int | None = None) -> str:
    """``0x6098 homing method`` (with ``:1`` for a sub-index)."""
    sub = f':{subindex}' if subindex else ''
    return f'0x{index:04X}{sub} {OBJECT_NAMES.get(index, "")}'.rstrip()


@dataclass
class ProcessData:
    """What the drive last sent: statusword, position [counts], velocity [counts/s], torque
    [per mille], digital inputs, with the monotonic times of its last TPDO and heartbeat, the
    EMCYs not yet taken (code, register) and whether it booted since last looked at."""

    statusword: int = 0
    position: int = 0
    velocity: int = 0
    torque: int = 0
    inputs: int = 0
    tpdo_time: float | None = None
    heartbeat_time: float | None = None
    emergencies: list = field(default_factory=list)
    booted: bool = False

    @property
    def state(self) -> State | None:
        return state_of(self.statusword)


class RemoteDrive:
    """One leg's drive on ``network`` (see the module docstring)."""

    def __init__(self, network: canopen.Network, config: DriveConfig, eds: str, *, mode: Mode,
                 sdo_timeout: float, sdo_retries: int = 2, digital_io: bool = False):
        self.config, self.eds, self.mode, self.digital_io = config, eds, mode, digital_io
        self.name = config.actuator
        try:
            self.node = canopen.RemoteNode(config.node_id, eds)
        except Exception as exc:  # noqa: BLE001 - the EDS parser raises many kinds
            raise ConfigureError(f'{self.name}: cannot read its EDS {eds}: {exc}') from exc
        self.node.sdo.RESPONSE_TIMEOUT = sdo_timeout
        self.node.sdo.MAX_RETRIES = 1 + sdo_retries  # canopen counts the first request
        network.add_node(self.node)
        self.scale = AxisScale(config)
        self.data = ProcessData()
        self.lock = threading.Lock()
        self.node.nmt.add_heartbeat_callback(self._on_heartbeat)
        self.node.emcy.add_callback(self._on_emcy)
        # what the cycle sends: controlword, target position [counts], target torque [per mille], outputs
        self.controlword, self.target, self.target_torque, self.outputs = 0, 0, 0, 0
        self.homed = config.homing == HOMING_ABSOLUTE
        #: what its configuration skipped or could not check, for the operator ('{drive}' names it)
        self.notes: list[str] = []

    def __str__(self) -> str:
        return f'{self.name} (node {self.config.node_id})'

    # --- objects by SDO (blocking, never from the receive thread) ---

    def _variable(self, index: int, subindex: int | None):
        return self.node.sdo[index] if subindex is None else self.node.sdo[index][subindex]

    def read_object(self, index: int, subindex: int | None = None):
        """An object's value (ConfigureError naming it when unanswered or refused)."""
        try:
            if index in self.node.object_dictionary:
                return self._variable(index, subindex).raw
            return int.from_bytes(self.node.sdo.upload(index, subindex or 0), 'little')
        except SdoCommunicationError:
            raise ConfigureError(f'{self}: no answer reading {object_text(index, subindex)} (SDO timeout '
                                 f'{self.node.sdo.RESPONSE_TIMEOUT} s, {self.node.sdo.MAX_RETRIES} tries): wrong node '
                                 'id, the drive is off, or the bus is not connected') from None
        except SdoAbortedError as exc:
            raise ConfigureError(f'{self}: reading {object_text(index, subindex)} refused: {exc}') from None

    def probe(self, index: int, subindex: int = 0, *, signed: bool = False) -> int | None:
        """An object's value read without its EDS (the raw bytes as an integer), or None when
        the drive has no such object (ConfigureError when unanswered or otherwise refused)."""
        try:
            return int.from_bytes(self.node.sdo.upload(index, subindex), 'little', signed=signed)
        except SdoAbortedError as exc:
            if exc.code in NO_OBJECT:
                return None
            raise ConfigureError(f'{self}: reading {object_text(index, subindex)} refused: {exc}') from None
        except SdoCommunicationError:
            raise ConfigureError(f'{self}: no answer reading {object_text(index, subindex)} (SDO timeout)') from None

    def write_object(self, index: int, subindex: int | None, value) -> None:
        """Write an object (ConfigureError naming it and the value when unanswered or refused)."""
        try:
            self._variable(index, subindex).raw = value
        except SdoCommunicationError:
            raise ConfigureError(f'{self}: no answer writing {object_text(index, subindex)} (SDO timeout)') from None
        except SdoAbortedError as exc:
            raise ConfigureError(f'{self}: writing {object_text(index, subindex)} = {value} refused: {exc}',
                                 exc.code, str(exc)) from None

    def take_process_data(self) -> None:
        """Start the process data from the drive's statusword and position (by SDO), holding there."""
        statusword, position = self.read_object(0x6041), self.read_object(0x6064)
        with self.lock:
            self.data = ProcessData(statusword=statusword, position=position)
        self.target, self.target_torque = position, 0
        self.controlword = keep_word(state_of(statusword))

    def start(self) -> None:
        """NMT OPERATIONAL: the PDOs run."""
        self.node.nmt.send_command(0x01)

    # --- the receive thread ---

    def on_tpdo(self, pdo) -> None:
        """A TPDO of the drive arrived (canopen's receive thread)."""
        now = time.monotonic()
        with self.lock:
            d = self.data
            for var in pdo.map:
                if var.index == 0x6041:
                    d.statusword = var.raw
                elif var.index == 0x6064:
                    d.position = var.raw
                elif var.index == 0x606C:
                    d.velocity = var.raw
                elif var.index == 0x6077:
                    d.torque = var.raw
                elif var.index == 0x60FD:
                    d.inputs = var.raw
            d.tpdo_time = now

    def _on_heartbeat(self, state: int) -> None:
        with self.lock:
            self.data.heartbeat_time = time.monotonic()
            if state == BOOT_UP:
                self.data.booted = True

    def _on_emcy(self, error) -> None:
        with self.lock:
            self.data.emergencies.append((error.code, error.register, error.get_desc()))

    def snapshot(self) -> ProcessData:
        """A copy of the process data; the EMCYs and the boot-up flag are taken (cleared)."""
        with self.lock:
            d = self.data
            copy = ProcessData(d.statusword, d.position, d.velocity, d.torque, d.inputs, d.tpdo_time,
                               d.heartbeat_time, list(d.emergencies), d.booted)
            d.emergencies.clear()
            d.booted = False
        return copy

    # --- the cycle thread ---

    def send_rpdos(self) -> None:
        """Fill and send the RPDOs (controlword, target, outputs): they take effect at the SYNC."""
        first = self.node.rpdo.map[1]
        first.map[0].raw = self.controlword
        first.map[1].raw = self.target if self.mode is Mode.CYCLIC_SYNCHRONOUS_POSITION else self.target_torque
        first.transmit()
        if self.digital_io:
            second = self.node.rpdo.map[2]
            second.map[0].raw = self.outputs
            second.transmit()


def keep_word(state: State | None) -> int:
    """The controlword that keeps a drive in its power state (and never resets a fault)."""
    return {State.OPERATION_ENABLED: 0x0F, State.SWITCHED_ON: 0x07, State.READY_TO_SWITCH_ON: 0x06,
            State.QUICK_STOP_ACTIVE: 0x02}.get(state, 0x00)
