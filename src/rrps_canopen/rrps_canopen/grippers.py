"""The grippers on digital I/O (a CiA 401 module or the drives' own, as ``bus.grippers`` says): a
fail-safe valve output and a clamp sensor per ring, and the interlock on the sensors. A sensor
that disagrees with its command past ``sensor_timeout`` is a fault; a fault never switches an
output. Wiring: docs/connecting-a-robot.md. Pure Python (canopen), no ROS import."""

from __future__ import annotations

import threading
import time
from typing import Callable, Mapping

import canopen
from canopen.sdo import SdoAbortedError, SdoCommunicationError

from rrps_canopen.drive import BOOT_UP, ConfigureError, RemoteDrive
from rrps_description.bus import GripperIoConfig
from rrps_description.names import RINGS
from rrps_hardware.interface import FaultKind

__all__ = ['GripperIo', 'IO_MODULE']

#: The actuator name of the grippers' I/O module in faults.
IO_MODULE = 'gripper_io'


def gripper_name(ring: str) -> str:
    return f'{ring}_gripper'


class GripperIo:
    """Both rings' grippers (see the module docstring). ``latch(name, kind, detail, now)``
    reports a fault; ``kinds``: the robot's gripper kinds (a ring with ``'none'`` has none)."""

    def __init__(self, config: GripperIoConfig, network: canopen.Network, drives: Mapping[str, RemoteDrive],
                 kinds: Mapping[str, str], eds: str, *, sdo_timeout: float, heartbeat_timeout: float,
                 latch: Callable[[str, FaultKind, str, float], None], sdo_retries: int = 2):
        self.config, self.kinds, self.latch = config, dict(kinds), latch
        self.heartbeat_timeout = heartbeat_timeout
        self.rings = {ring: ch for ring, ch in config.rings.items() if self.kinds.get(ring, 'none') != 'none'}
        self.drives = drives
        self.lock = threading.Lock()
        self.node: canopen.RemoteNode | None = None
        self.inputs = 0
        self.heartbeat: float | None = None
        self.booted = False
        if config.io == 'cia401':
            try:
                self.node = canopen.RemoteNode(config.node_id, eds)
            except Exception as exc:  # noqa: BLE001 - the EDS parser raises many kinds
                raise ConfigureError(f'{IO_MODULE}: cannot read its EDS {eds}: {exc}') from exc
            self.node.sdo.RESPONSE_TIMEOUT = sdo_timeout
            self.node.sdo.MAX_RETRIES = 1 + sdo_retries  # canopen counts the first request
            network.add_node(self.node)
            self.node.nmt.add_heartbeat_callback(self._on_heartbeat)
        self.outputs = 0
        self.configured = False  # the sensors are judged once the outputs and inputs were read
        self.commanded = {ring: True for ring in RINGS}
        self.disagree_since: dict[str, float | None] = {ring: None for ring in RINGS}

    # --- bring-up ---

    def _sdo(self, index: int, subindex: int, value=None):
        try:
            var = self.node.sdo[index][subindex] if subindex is not None else self.node.sdo[index]
            if value is None:
                return var.raw
            var.raw = value
        except SdoCommunicationError:
            raise ConfigureError(f'{IO_MODULE} (node {self.config.node_id}): no answer (SDO timeout): wrong node id, '
                                 'or the module is off') from None
        except SdoAbortedError as exc:
            raise ConfigureError(f'{IO_MODULE} (node {self.config.node_id}): 0x{index:04X} refused: {exc}') from None
        return None

    def check(self) -> None:
        """ConfigureError unless the module (if any) is a CiA 401 device that matches its EDS."""
        if self.node is None:
            return
        od = self.node.object_dictionary
        missing = [f'0x{i:04X}' for i in (0x6000, 0x6200) if i not in od]
        if missing:
            raise ConfigureError(f'{IO_MODULE}: its EDS lacks {", ".join(missing)}: not a CiA 401 I/O module EDS')
        device_type, product = self._sdo(0x1000, None), self._sdo(0x1018, 2)
        if device_type & 0xFFFF != 401 or product != od.device_information.product_number:
            raise ConfigureError(f'{IO_MODULE} (node {self.config.node_id}): device type 0x{device_type:08X}, product '
                                 f'0x{product:08X} is not the CiA 401 module its EDS describes: wrong EDS or node id')

    def configure(self, heartbeat_period: float) -> None:
        """Map the module's PDOs and read the outputs as they are (nothing switches). A boot-up
        heard before is the module's power-on (it may boot after the master starts), not a reboot."""
        self.heartbeat_period = heartbeat_period
        with self.lock:
            self.booted = False
        if self.node is None:
            outputs = {}
            for ring, channel in self.rings.items():
                drive = self.drives[channel.drive]
                drive.outputs = outputs[ring] = drive.read_object(0x60FE, 1)
        else:
            node = self.node
            node.nmt.send_command(0x80)
            self._sdo(0x1017, None, max(1, round(heartbeat_period * 1000)))
            node.rpdo.read(from_od=True)
            node.tpdo.read(from_od=True)
            for maps, index, trans in ((node.rpdo, 0x6200, 255), (node.tpdo, 0x6000, 1)):
                for number, pdo in maps.map.items():
                    pdo.clear()
                    if number == 1:
                        pdo.add_variable(index, 1)
                    pdo.trans_type, pdo.enabled = trans, number == 1
            try:
                node.rpdo.save()
                node.tpdo.save()
            except (SdoCommunicationError, SdoAbortedError) as exc:
                raise ConfigureError(f'{IO_MODULE}: its PDO mapping failed: {exc}') from None
            if self._on_tpdo not in node.tpdo.map[1].callbacks:
                node.tpdo.map[1].add_callback(self._on_tpdo)
            self.outputs = self._sdo(0x6200, 1)
            self.inputs = self._sdo(0x6000, 1)
            outputs = {ring: self.outputs for ring in self.rings}
            node.nmt.send_command(0x01)
        now = time.monotonic()
        for ring, channel in self.rings.items():
            self.commanded[ring] = not outputs[ring] >> channel.output & 1
            self.disagree_since[ring] = None
        self.heartbeat = now if self.node is not None else None
        self.configured = True

    # --- the receive thread ---

    def _on_tpdo(self, pdo) -> None:
        with self.lock:
            self.inputs = pdo.map[0].raw

    def _on_heartbeat(self, state: int) -> None:
        with self.lock:
            self.heartbeat = time.monotonic()
            self.booted = self.booted or state == BOOT_UP

    # --- state ---

    def sensors(self) -> dict[str, bool]:
        """{ring: closed} as the clamp sensors read (a ring without a gripper: closed)."""
        closed = {ring: True for ring in RINGS}
        with self.lock:
            inputs = self.inputs
        for ring, channel in self.rings.items():
            word = inputs if self.node is not None else self.drives[channel.drive].data.inputs
            closed[ring] = bool(word >> channel.sensor & 1)
        return closed

    def cycle(self, now: float, alive: bool = True) -> None:
        """Each cycle: the module's heartbeat and boot-up (its heartbeat is lost only while the
        drives are ``alive``: else the bus or this process is the matter), and each sensor
        against its command; nothing before :meth:`configure`."""
        if not self.configured:
            return
        if self.node is not None:
            with self.lock:
                booted, self.booted, heartbeat = self.booted, False, self.heartbeat
            if booted:
                self.latch(IO_MODULE, FaultKind.REBOOTED, 'boot-up message: its outputs restarted de-energised', now)
                threading.Thread(target=self._reconfigure, name='reconfigure-gripper-io', daemon=True).start()
            elif alive and heartbeat is not None and now - heartbeat > self.heartbeat_timeout:
                self.latch(IO_MODULE, FaultKind.LOST_HEARTBEAT, f'no heartbeat for {now - heartbeat:.3f} s', now)
        sensors = self.sensors()
        for ring in self.rings:
            if sensors[ring] == self.commanded[ring]:
                self.disagree_since[ring] = None
                continue
            since = self.disagree_since[ring]
            if since is None:
                self.disagree_since[ring] = now
            elif now - since > self.config.sensor_timeout:
                state = 'closed' if sensors[ring] else 'open'
                wanted = 'closed' if self.commanded[ring] else 'open'
                self.latch(gripper_name(ring), FaultKind.GRIPPER_SENSOR,
                           f'clamp sensor reads {state}, commanded {wanted}, for {now - since:.2f} s', now)

    def _reconfigure(self) -> None:
        try:
            time.sleep(0.05)
            self.configure(self.heartbeat_period)
        except ConfigureError as exc:
            self.latch(IO_MODULE, FaultKind.REBOOTED, f'not configured again: {exc}', time.monotonic())

    def resync(self) -> list[str]:
        """At a fault reset: the commands become what the outputs are now; the rings whose sensor
        still disagrees (the reset is refused while there are any)."""
        for ring, channel in self.rings.items():
            word = self.outputs if self.node is not None else self.drives[channel.drive].outputs
            self.commanded[ring] = not word >> channel.output & 1
            self.disagree_since[ring] = None
        return self.disagreeing()

    def disagreeing(self) -> list[str]:
        """The rings whose sensor disagrees with the command now."""
        sensors = self.sensors()
        return [ring for ring in self.rings if sensors[ring] != self.commanded[ring]]

    def set(self, ring: str, close: bool) -> tuple[bool, str]:
        """Close or open ``ring``'s clamp; (accepted, message). Opening needs the other ring's
        sensor to read closed."""
        if ring not in self.rings:
            return False, f'{ring} has no gripper on the bus'
        other = RINGS[1] if ring == RINGS[0] else RINGS[0]
        if not close:
            sensors = self.sensors()
            if not (sensors[other] and self.commanded[other]):
                return False, (f'refused: opening {ring} would leave no ring gripping ({other} '
                               f'{"is commanded open" if not self.commanded[other] else "reads open on its sensor"})')
        channel = self.rings[ring]
        self.commanded[ring] = close
        self.disagree_since[ring] = time.monotonic()
        bit = 1 << channel.output
        if self.node is not None:
            self.outputs = self.outputs & ~bit if close else self.outputs | bit
            rpdo = self.node.rpdo.map[1]
            rpdo.map[0].raw = self.outputs
            rpdo.transmit()
        else:
            drive = self.drives[channel.drive]
            drive.outputs = drive.outputs & ~bit if close else drive.outputs | bit
        return True, f'{ring} {"closing" if close else "opening"}'
