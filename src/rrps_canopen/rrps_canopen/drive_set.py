"""The drives of one CAN bus and its cycle thread: one SYNC per ``sync_period``, fault detection
and latching, holding, enabling, homing and the fault reset.

A new fault makes every drive hold where it is and sets ``faulted``; nothing then enables a drive
or resets a fault but :meth:`DriveSet.enable` and :meth:`DriveSet.reset` (the operator's
activation and fault reset). Fault reactions: docs/connecting-a-robot.md. Pure Python.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import deque
from typing import Callable

import can
import canopen

from rrps_canopen.bringup import check, configure, fail, grouped, reconfigure, wait_for_drives
from rrps_canopen.cia402 import Controlword, Mode, State, Statusword, controlword_toward
from rrps_canopen.drive import ConfigureError, ProcessData, RemoteDrive, keep_word
from rrps_canopen.network import open_network, resolve_eds
from rrps_description.bus import BusConfig
from rrps_hardware.interface import ActuatorFault, FaultKind

__all__ = ['DriveSet', 'BusOffListener', 'ConfigureError']

#: CAN error-frame class bit of a bus-off (SocketCAN's CAN_ERR_BUSOFF).
CAN_ERR_BUSOFF = 0x40
#: The drives count as alive while one of them was heard this many periods ago (at least
#: ALIVE_MIN s): a drive's lost heartbeat is then its own, not the bus'.
ALIVE_PERIODS, ALIVE_MIN = 5, 0.01
#: A cycle this fraction of the heartbeat timeout after the one before: this process did not run
#: (a stall of its computer), so it cannot tell a drive's silence from its own until the frames
#: that arrived meanwhile are read; heartbeats are judged again one heartbeat timeout later.
STALL_FRACTION = 0.5
#: The switch interval of the process' threads [s]: the SYNC thread gets the interpreter within it.
SWITCH_INTERVAL = 5e-4
_FAULTED = (State.FAULT, State.FAULT_REACTION_ACTIVE)


class BusOffListener(can.Listener):
    """Notes the error frames that report the controller bus-off."""

    def __init__(self):
        self.bus_off = threading.Event()

    def on_message_received(self, msg: can.Message) -> None:
        if msg.is_error_frame and msg.arbitration_id & CAN_ERR_BUSOFF:
            self.bus_off.set()


class DriveSet:
    """The drives of ``bus`` in ``mode`` (see the module docstring). ``extra`` is called each
    cycle under the lock, before the SYNC (the grippers' I/O); ``digital_io``: the drives whose
    digital I/O carries the grippers."""

    def __init__(self, bus: BusConfig, mode: Mode, *, digital_io: frozenset[str] = frozenset(),
                 extra: Callable[[float], None] | None = None):
        self.bus, self.mode, self.extra = bus, mode, extra
        self.period = bus.sync_period
        self.lock = threading.RLock()
        self.listener = BusOffListener()
        self.network: canopen.Network = open_network(bus, (self.listener,))
        try:
            self.drives = [RemoteDrive(self.network, d, resolve_eds(d.eds, bus.base_dir), mode=mode,
                                       sdo_timeout=bus.sdo_timeout, sdo_retries=bus.sdo_retries,
                                       digital_io=d.actuator in digital_io)
                           for d in bus.drives]
        except (ConfigureError, FileNotFoundError):
            self.network.disconnect()
            raise
        self.data = {d.name: ProcessData() for d in self.drives}
        self.faults: dict[str, ActuatorFault] = {}
        self.fault_times: dict[str, float] = {}
        self.bus_lost = False
        #: a drive was heard within a few periods (this process ran and the bus carries frames),
        #: and this process is not catching up after a stall (STALL_FRACTION)
        self.alive = False
        self._last_cycle: float | None = None
        self._catching_up_until = -1.0  # after a stall of this process (STALL_FRACTION)
        self.want: dict[str, State | None] = {d.name: None for d in self.drives}
        self._quick_stop: set[str] = set()
        self._reset_cycles: dict[str, int] = {}
        self._resetting: set[str] = set()
        #: the drives whose controlword carries the homing start bit (4) while enabled
        self.homing_start: set[str] = set()
        self._rebooting: set[str] = set()
        self.sync_times: deque[float] = deque(maxlen=100_000)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # --- bring-up ---

    def configure(self) -> None:
        """Wait for every drive (``bus.boot_timeout``), check every drive, then configure every
        drive, then start them (OPERATIONAL) and wait for each one's first heartbeat and TPDO;
        ConfigureError naming the drive and every problem otherwise (the drives are then sent back
        to PRE-OPERATIONAL: nothing runs half-configured). What was skipped: :attr:`notes`."""
        try:
            wait_for_drives(self.drives, self.bus.boot_timeout)
            fail([problem for d in self.drives for problem in check(d, homes=not d.homed)])
            for d in self.drives:
                configure(d, heartbeat_period=self.bus.heartbeat_period, sync_period=self.period)
            for d in self.drives:
                d.start()
            self.start_cycle()
            self._wait_for_first_data()
        except ConfigureError:
            self.close(stop_drives=True)
            raise

    @property
    def notes(self) -> str:
        """What the bring-up skipped or could not check, a sentence per kind naming the drives."""
        return grouped([(d, note) for d in self.drives for note in d.notes])

    def _wait_for_first_data(self) -> None:
        deadline = time.monotonic() + max(1.0, 3 * self.bus.heartbeat_timeout)
        while time.monotonic() < deadline:
            with self.lock:
                silent = [d for d in self.drives if self.data[d.name].tpdo_time is None
                          or self.data[d.name].heartbeat_time is None]
            if not silent:
                return
            time.sleep(self.period)
        raise ConfigureError(f'{", ".join(map(str, silent))}: no heartbeat or PDO after configuration')

    def start_cycle(self) -> None:
        sys.setswitchinterval(SWITCH_INTERVAL)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name='canopen-sync', daemon=True)
        self._thread.start()

    def close(self, *, stop_drives: bool = False) -> None:
        """Stop the cycle (and, with ``stop_drives``, send the drives to PRE-OPERATIONAL); disconnect."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None
        if stop_drives and self.network.bus is not None:
            try:
                self.network.nmt.send_command(0x80)
            except can.CanError:
                pass
        if self.network.bus is not None:
            self.network.disconnect()

    # --- the cycle ---

    def _run(self) -> None:
        deadline = time.monotonic()
        while not self._stop.is_set():
            deadline += self.period
            delay = deadline - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                deadline = time.monotonic()  # late: no burst to catch up
            try:
                self.cycle(time.monotonic())
            except Exception as exc:  # noqa: BLE001 - a defect must not end the SYNCs silently
                self._lose_bus(f'the CANopen cycle failed: {exc!r}', time.monotonic())

    def cycle(self, now: float) -> None:
        with self.lock:
            snaps = [d.snapshot() for d in self.drives]
            heard = max(max(t for t in (s.tpdo_time, s.heartbeat_time, 0.0) if t is not None) for s in snaps)
            if self._last_cycle is not None and now - self._last_cycle > STALL_FRACTION * self.bus.heartbeat_timeout:
                self._catching_up_until = now + self.bus.heartbeat_timeout
            self._last_cycle = now
            alive = self.alive = (now - heard < max(ALIVE_PERIODS * self.period, ALIVE_MIN)
                                  and now >= self._catching_up_until)
            for d, snap in zip(self.drives, snaps):
                self._look_at(d, snap, now, alive)
            self._watch_bus(now, heard)
            for d in self.drives:
                d.controlword = self._controlword(d)
            if self.extra is not None:
                self.extra(now)
            try:
                for d in self.drives:
                    if d.name not in self._rebooting:   # PRE-OPERATIONAL, its PDOs being mapped again
                        d.send_rpdos()
                self.network.sync.transmit()
                self.sync_times.append(time.monotonic())
            except (can.CanError, OSError) as exc:
                self._lose_bus(f'send failed: {exc}', now)

    def _look_at(self, d: RemoteDrive, snap: ProcessData, now: float, alive: bool) -> None:
        previous = self.data[d.name]
        self.data[d.name] = snap
        if snap.booted:
            d.homed = d.config.homing == 'absolute'
            self.latch(d.name, FaultKind.REBOOTED, 'boot-up message: configured again, stays disabled', now)
            self._reconfigure(d)
            return
        for code, register, meaning in snap.emergencies:
            if code & 0xFF00:
                kind = FaultKind.FOLLOWING_ERROR if code == 0x8611 else FaultKind.EMERGENCY
                self.latch(d.name, kind, f'EMCY 0x{code:04X} {meaning}'.strip(), now)
        if d.name in self._rebooting:
            return
        if snap.state in _FAULTED and snap.tpdo_time != previous.tpdo_time:
            following = self.mode is Mode.CYCLIC_SYNCHRONOUS_POSITION and snap.statusword & Statusword.MODE_SPECIFIC_13
            self.latch(d.name, FaultKind.FOLLOWING_ERROR if following else FaultKind.DRIVE_FAULT,
                       'fault bit in the statusword', now)
        hb = snap.heartbeat_time
        if alive and hb is not None and now - hb > self.bus.heartbeat_timeout:
            self.latch(d.name, FaultKind.LOST_HEARTBEAT, f'no heartbeat for {now - hb:.3f} s', now)

    def _unanswered(self, heard: float) -> int:
        """How many SYNCs went out since the last frame heard (a process that did not run sent none)."""
        count = 0
        for t in reversed(self.sync_times):
            if t <= heard:
                break
            count += 1
        return count

    def _watch_bus(self, now: float, heard: float) -> None:
        """The bus is lost on a bus-off, or when no drive answered the SYNCs of a heartbeat
        timeout (and half as many SYNCs went out); back when every drive is heard again (its
        faults stay latched until reset)."""
        silence = self.bus.heartbeat_timeout
        if self.listener.bus_off.is_set():
            self.listener.bus_off.clear()
            self._lose_bus('the CAN controller is bus-off', now)
        elif not self.bus_lost and now - heard > silence and \
                self._unanswered(heard) >= max(3, int(0.5 * silence / self.period)):
            self._lose_bus(f'no frame from any drive for {now - heard:.3f} s', now)
        elif self.bus_lost and all(max(t for t in (s.tpdo_time, s.heartbeat_time, 0.0) if t is not None) > now - silence
                                   for s in self.data.values()):
            self.bus_lost = False

    def _lose_bus(self, why: str, now: float) -> None:
        self.bus_lost = True
        for d in self.drives:
            self.latch(d.name, FaultKind.BUS_LOST, why, now)

    def latch(self, name: str, kind: FaultKind, detail: str, now: float) -> None:
        """Latch a fault (a vaguer one is replaced by a precise one): every drive holds, the
        faulted one stops."""
        with self.lock:
            self._latch(name, kind, detail, now)

    def _latch(self, name: str, kind: FaultKind, detail: str, now: float) -> None:
        old = self.faults.get(name)
        if old is not None and not (old.kind is FaultKind.DRIVE_FAULT and kind in (FaultKind.EMERGENCY,
                                                                                   FaultKind.FOLLOWING_ERROR)):
            return
        self.faults[name] = ActuatorFault(name, kind, detail)
        if old is None:
            self.fault_times[name] = now
            self._quick_stop.add(name)
            self.want[name] = None
            self.homing_start.discard(name)
            self.hold()

    def hold(self) -> None:
        """Every drive's target becomes where it is."""
        with self.lock:
            for d in self.drives:
                d.target = self.data[d.name].position
                d.target_torque = 0

    def _controlword(self, d: RemoteDrive) -> int:
        state = self.data[d.name].state
        if d.name in self._reset_cycles:
            left = self._reset_cycles[d.name]
            self._reset_cycles[d.name] = left - 1
            if left <= 1:
                del self._reset_cycles[d.name]
            return int(Controlword.FAULT_RESET) if left <= 2 else 0x00
        if d.name in self._resetting:
            return int(Controlword.DISABLE_VOLTAGE)
        if d.name in self.faults:
            if d.name in self._rebooting or self.faults[d.name].kind is FaultKind.REBOOTED:
                return 0x00
            if d.name in self._quick_stop and state is State.OPERATION_ENABLED:
                return int(Controlword.QUICK_STOP)
            return keep_word(state)
        want = self.want[d.name]
        word = None if want is None else controlword_toward(state, want)
        word = keep_word(state) if word is None else word
        if d.name in self.homing_start and state is State.OPERATION_ENABLED:
            word |= Controlword.HOMING_START
        return word

    def _reconfigure(self, d: RemoteDrive) -> None:
        """Configure a rebooted drive again (its PDOs, heartbeat, limits), in the background."""
        if d.name in self._rebooting:
            return
        self._rebooting.add(d.name)

        def job() -> None:
            try:
                time.sleep(2 * self.period)
                reconfigure(d, heartbeat_period=self.bus.heartbeat_period, sync_period=self.period)
            except ConfigureError as exc:
                with self.lock:
                    self.faults[d.name] = ActuatorFault(d.name, FaultKind.REBOOTED, f'not configured again: {exc}')
            finally:
                with self.lock:
                    self._rebooting.discard(d.name)

        threading.Thread(target=job, name=f'reconfigure-{d.name}', daemon=True).start()

    # --- the operator's requests (blocking; never from the cycle or receive threads) ---

    def wait(self, done: Callable[[], str | None], timeout: float, what: str, *, faults: int = 0) -> str:
        """Poll ``done`` (None when done, else what is missing) each period, while no more than
        ``faults`` faults are latched; '' or the reason."""
        deadline = time.monotonic() + timeout
        while True:
            with self.lock:
                missing = done()
                if missing is None:
                    return ''
                if len(self.faults) > faults:
                    return f'{what} stopped by a fault: {"; ".join(map(str, self.faults.values()))}'
            if time.monotonic() > deadline:
                return f'{what} timed out after {timeout:.1f} s: {missing}'
            time.sleep(self.period)

    def enable(self, timeout: float = 2.0, *, drives: list[RemoteDrive] | None = None) -> str:
        """Every drive (or ``drives``) to OPERATION ENABLED, holding where it is; '' or why not."""
        drives = self.drives if drives is None else drives
        with self.lock:
            if self.faults:
                return f'{"; ".join(map(str, self.faults.values()))}: reset the faults first'
            self.hold()
            for d in drives:
                self.want[d.name] = State.OPERATION_ENABLED
                self._quick_stop.discard(d.name)

        def missing() -> str | None:
            off = [f'{d.name} {getattr(self.data[d.name].state, "value", "invalid statusword")}'
                   for d in drives if self.data[d.name].state is not State.OPERATION_ENABLED]
            return ', '.join(off) or None
        return self.wait(missing, timeout, 'enabling')

    def disable(self, timeout: float = 2.0) -> str:
        """Every drive to SWITCH ON DISABLED (no torque: nothing moves); '' or why not."""
        with self.lock:
            self.hold()
            self.homing_start.clear()
            for d in self.drives:
                self.want[d.name] = State.SWITCH_ON_DISABLED

        def missing() -> str | None:
            on = [f'{d.name} {getattr(self.data[d.name].state, "value", "invalid statusword")}' for d in self.drives
                  if self.data[d.name].state not in (State.SWITCH_ON_DISABLED, *_FAULTED)]
            return ', '.join(on) or None
        return self.wait(missing, timeout, 'disabling', faults=len(self.faults))

    def reset(self, timeout: float = 1.0) -> str:
        """Reset the latched faults (CiA 402 fault reset of the faulted drives); the faulted
        drives end SWITCH ON DISABLED; '' or why not."""
        now = time.monotonic()
        with self.lock:
            if self.bus_lost:
                return 'the bus is lost: no fault reset'
            silent = [d.name for d in self.drives if self.data[d.name].heartbeat_time is None
                      or now - self.data[d.name].heartbeat_time > self.bus.heartbeat_timeout]
            busy = sorted(self._rebooting)
            if silent or busy:
                return f'{", ".join(silent + busy)} not answering yet: no fault reset'
            faulted = [d for d in self.drives if d.name in self.faults]
            latched = dict(self.faults)
            for d in faulted:
                self.want[d.name] = None
                self._quick_stop.discard(d.name)
                self._resetting.add(d.name)
                if self.data[d.name].state in _FAULTED:
                    self._reset_cycles[d.name] = 3

        def missing() -> str | None:
            left = [d.name for d in faulted if self.data[d.name].state is not State.SWITCH_ON_DISABLED]
            return ', '.join(left) or None
        reason = self.wait(missing, timeout, 'fault reset', faults=len(latched))
        with self.lock:
            self._resetting.difference_update(d.name for d in faulted)
            if not reason:
                for name, fault in latched.items():
                    if self.faults.get(name) == fault:
                        del self.faults[name]
        return reason
