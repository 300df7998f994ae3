"""One CiA 402 drive as the backend sees it: its checks and configuration by SDO, its process data.

:class:`RemoteDrive` wraps canopen's ``RemoteNode``. ``check`` compares what the drive says it is
(device type 0x1000, vendor and product 0x1018) with its EDS and that the EDS has the objects
the mode needs; ``configure`` sets it up by SDO (heartbeat producer, quick-stop option "stop and
stay", following-error window, soft limits, interpolation period, homing, the PDO mapping for
cyclic synchronous position or torque mode: RPDO1 controlword + target, TPDO1 statusword +
position on every SYNC, TPDO2 velocity + torque, and the digital I/O when the grippers are on
the drive). Its
TPDOs, heartbeat and EMCYs update :class:`ProcessData` from canopen's receive thread. Pure
Python (canopen), no ROS import.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

from canopen.sdo import SdoAbortedError, SdoCommunicationError

import canopen
from rrps_canopen.cia402 import Mode, State, state_of
from rrps_canopen.units import AxisScale
from rrps_description.bus import HOMING_ABSOLUTE, DriveConfig

__all__ = ['ConfigureError', 'RemoteDrive', 'ProcessData', 'REQUIRED_OBJECTS']

#: The objects a drive's EDS must have, per mode (index: name).
REQUIRED_OBJECTS = {
    Mode.CYCLIC_SYNCHRONOUS_POSITION: {0x6040: 'controlword', 0x6041: 'statusword', 0x6060: 'modes of operation',
                                       0x6064: 'position actual value', 0x607A: 'target position',
                                       0x606C: 'velocity actual value', 0x6077: 'torque actual value',
                                       0x6076: 'motor rated torque'},
    Mode.CYCLIC_SYNCHRONOUS_TORQUE: {0x6040: 'controlword', 0x6041: 'statusword', 0x6060: 'modes of operation',
                                     0x6064: 'position actual value', 0x6071: 'target torque',
                                     0x606C: 'velocity actual value', 0x6077: 'torque actual value',
                                     0x6076: 'motor rated torque'},
}
#: Heartbeat state of a boot-up message.
BOOT_UP = 0
#: In position mode the drive's velocity and torque (TPDO2) go out every this many SYNCs (they
#: inform, they do not close a loop); in torque mode every SYNC (the force output's damping).
SLOW_TPDO_EVERY = 5


class ConfigureError(Exception):
    """A drive or its EDS is not what the robot YAML says (the message names the drive)."""


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
                 sdo_timeout: float, digital_io: bool = False):
        self.config, self.eds, self.mode, self.digital_io = config, eds, mode, digital_io
        self.name = config.actuator
        try:
            self.node = canopen.RemoteNode(config.node_id, eds)
        except Exception as exc:  # noqa: BLE001 - the EDS parser raises many kinds
            raise ConfigureError(f'{self.name}: cannot read its EDS {eds}: {exc}') from exc
        self.node.sdo.RESPONSE_TIMEOUT = sdo_timeout
        network.add_node(self.node)
        self.scale = AxisScale(config)
        self.data = ProcessData()
        self.lock = threading.Lock()
        self.node.nmt.add_heartbeat_callback(self._on_heartbeat)
        self.node.emcy.add_callback(self._on_emcy)
        # what the cycle sends: controlword, target position [counts], target torque [per mille], outputs
        self.controlword, self.target, self.target_torque, self.outputs = 0, 0, 0, 0
        self.homed = config.homing == HOMING_ABSOLUTE

    def __str__(self) -> str:
        return f'{self.name} (node {self.config.node_id})'

    # --- checks and configuration (SDO: blocking, never from the receive thread) ---

    def read_object(self, index: int, subindex: int | None = None):
        try:
            obj = self.node.sdo[index] if subindex is None else self.node.sdo[index][subindex]
            return obj.raw
        except SdoCommunicationError:
            raise ConfigureError(f'{self}: no answer (SDO timeout {self.node.sdo.RESPONSE_TIMEOUT} s): wrong node id, '
                                 'the drive is off, or the bus is not connected') from None
        except SdoAbortedError as exc:
            raise ConfigureError(f'{self}: reading 0x{index:04X} refused: {exc}') from None

    def write_object(self, index: int, subindex: int | None, value) -> None:
        try:
            obj = self.node.sdo[index] if subindex is None else self.node.sdo[index][subindex]
            obj.raw = value
        except SdoCommunicationError:
            raise ConfigureError(f'{self}: no answer writing 0x{index:04X} (SDO timeout)') from None
        except SdoAbortedError as exc:
            raise ConfigureError(f'{self}: writing 0x{index:04X} refused: {exc}') from None

    def check(self) -> None:
        """ConfigureError unless the drive and its EDS agree and the EDS has the mode's objects."""
        od = self.node.object_dictionary
        missing = [f'0x{i:04X} {name}' for i, name in REQUIRED_OBJECTS[self.mode].items() if i not in od]
        if missing:
            raise ConfigureError(f'{self}: its EDS {self.eds} lacks {", ".join(missing)}: not a CiA 402 drive '
                                 'EDS for this mode')
        device_type = self.read_object(0x1000)
        vendor, product = self.read_object(0x1018, 1), self.read_object(0x1018, 2)
        info = od.device_information
        expected = (od[0x1000].default, info.vendor_number, info.product_number)
        if (device_type, vendor, product) != expected:
            raise ConfigureError(
                f'{self}: the drive reports device type 0x{device_type:08X}, vendor 0x{vendor:08X}, product '
                f'0x{product:08X} but its EDS {self.eds} describes 0x{expected[0]:08X}, 0x{expected[1] or 0:08X}, '
                f'0x{expected[2] or 0:08X}: wrong EDS or wrong node id')
        if device_type & 0xFFFF != 402:
            raise ConfigureError(f'{self}: device type 0x{device_type:08X} is not a CiA 402 drive')

    def configure(self, *, heartbeat_period: float, sync_period: float) -> None:
        """Set the drive up (PRE-OPERATIONAL, by SDO); it stays in its power state."""
        c, s = self.config, self.scale
        self.node.nmt.send_command(0x80)
        self.write_object(0x1017, None, max(1, round(heartbeat_period * 1000)))
        self.write_object(0x605A, None, 6)  # quick stop: stop, then stay in QUICK STOP ACTIVE, holding
        self.write_object(0x6065, None, s.distance_counts(c.following_error))
        self.write_object(0x6066, None, max(1, round(c.following_error_time * 1000)))
        lo, hi = s.limit_counts()
        self.write_object(0x607D, 1, lo)
        self.write_object(0x607D, 2, hi)
        if 0x60C2 in self.node.object_dictionary:
            self.write_object(0x60C2, 1, max(1, round(sync_period * 1000)))
            self.write_object(0x60C2, 2, -3)
        if c.homing != HOMING_ABSOLUTE:
            self.write_object(0x6098, None, c.homing)
            self.write_object(0x607C, None, s.counts(c.home_position))
            self.write_object(0x6099, 1, abs(s.counts_per_second(c.homing_speed)))
        if c.rated_force is not None:
            self.write_object(0x6076, None, round(c.rated_force * 1000.0))  # N -> mN
        s.rated_force = self.read_object(0x6076) / 1000.0  # mN -> N
        self.write_object(0x6060, None, int(self.mode))
        self._map_pdos()
        statusword, position = self.read_object(0x6041), self.read_object(0x6064)
        with self.lock:
            self.data = ProcessData(statusword=statusword, position=position)
        self.target, self.target_torque = position, 0
        self.controlword = keep_word(state_of(statusword))

    def _map_pdos(self) -> None:
        node = self.node
        node.rpdo.read(from_od=True)
        node.tpdo.read(from_od=True)
        second = 'Target position' if self.mode is Mode.CYCLIC_SYNCHRONOUS_POSITION else 'Target torque'
        rpdo = [[0x6040, 0x607A if second == 'Target position' else 0x6071]]
        tpdo = [[0x6041, 0x6064], [0x606C, 0x6077]]
        if self.digital_io:
            rpdo.append([(0x60FE, 1)])
            tpdo.append([0x60FD])
        slow = SLOW_TPDO_EVERY if self.mode is Mode.CYCLIC_SYNCHRONOUS_POSITION else 1
        for maps, wanted in ((node.rpdo, rpdo), (node.tpdo, tpdo)):
            for number, pdo in maps.map.items():
                pdo.clear()
                objects = wanted[number - 1] if number <= len(wanted) else []
                for obj in objects:
                    index, subindex = obj if isinstance(obj, tuple) else (obj, 0)
                    pdo.add_variable(index, subindex)
                pdo.trans_type = slow if maps is node.tpdo and number == 2 else 1
                pdo.enabled = bool(objects)
                if pdo.enabled and not pdo.cob_id:
                    pdo.cob_id = pdo.predefined_cob_id
        try:
            node.rpdo.save()
            node.tpdo.save()
        except SdoCommunicationError:
            raise ConfigureError(f'{self}: no answer while mapping its PDOs (SDO timeout)') from None
        except SdoAbortedError as exc:
            raise ConfigureError(f'{self}: its PDO mapping was refused: {exc}') from None
        for pdo in node.tpdo.map.values():
            if pdo.enabled and self._on_tpdo not in pdo.callbacks:
                pdo.add_callback(self._on_tpdo)

    def start(self) -> None:
        """NMT OPERATIONAL: the PDOs run."""
        self.node.nmt.send_command(0x01)

    # --- the receive thread ---

    def _on_tpdo(self, pdo) -> None:
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
