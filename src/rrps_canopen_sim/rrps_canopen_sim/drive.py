"""A simulated CiA 402 linear drive: the state machine, the modes of operation, homing, CSP and
CST, the following-error monitor, EMCY, and the faults a test injects.

On each SYNC the bus (:mod:`rrps_canopen_sim.bus`) takes the axis' reference
(:meth:`SimulatedDrive.reference`, :meth:`SimulatedDrive.force`), steps the actuator model and
hands back its position and speed (:meth:`SimulatedDrive.sense`). The encoder is absolute or
incremental (0 at power-on until homed). Pure Python (canopen), no ROS import.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import canopen
from canopen.sdo import SdoAbortedError

from rrps_canopen.cia402 import Controlword, DeviceStateMachine, Mode, State, Statusword
from rrps_canopen_sim.behaviour import DriveBehaviour
from rrps_canopen_sim.homing import HomingRun, Phase
from rrps_canopen_sim.node import SimulatedNode
from rrps_canopen_sim.objects import device_dictionary
from rrps_description.bus import HOMING_ABSOLUTE, DriveConfig

__all__ = ['SimulatedDrive', 'EMCY_CODES', 'VALUE_RANGE_EXCEEDED']

#: EMCY error codes (CiA 301 / 402) the simulator sends, and the error register bits with them.
EMCY_CODES = {
    'current': (0x2310, 0x03),          # continuous over-current: generic + current
    'following_error': (0x8611, 0x81),  # following error: generic + manufacturer
}
#: SDO abort code (CiA 301): value range of parameter exceeded (a value the drive refuses).
VALUE_RANGE_EXCEEDED = 0x06090030
_PDO_MAPPINGS = (range(0x1600, 0x1800), range(0x1A00, 0x1C00))
_INT32 = (-2**31, 2**31 - 1)


class SimulatedDrive(SimulatedNode):
    """One leg's drive (see the module docstring). ``config`` is how the real drive is mounted
    (counts per metre, direction, offset); ``stroke`` the axis' physical ends [m]; ``lock`` the
    bus' (a late power-on happens under it)."""

    def __init__(self, network: canopen.Network, config: DriveConfig, eds: str, stroke: tuple[float, float],
                 position: float, behaviour: DriveBehaviour | None = None, lock: threading.Lock | None = None):
        self.config, self.stroke = config, stroke
        self.behaviour = behaviour or DriveBehaviour()
        self.gain = config.direction * config.counts_per_metre
        self.x, self.v, self.applied_force = position, 0.0, 0.0
        #: The objects whose value the drive computes when read, by index (built once: every
        #: object a TPDO or a test reads asks :meth:`process_value` first).
        self._computed = {
            0x6041: self.statusword, 0x6064: self.counts, 0x606C: lambda: int(round(self.gain * self.v)),
            0x6077: self._torque_actual, 0x6061: lambda: int(self.mode_display),
            0x603F: lambda: self.error_code, 0x1001: lambda: self.error_register,
            0x60F4: lambda: self.target - self.counts(), 0x60FD: lambda: self.digital_inputs}
        super().__init__(network, config.node_id, eds, device_dictionary(eds, config.node_id, self.behaviour),
                         sdo_loss=self.behaviour.sdo_loss)
        self.on_reset()
        if self.behaviour.boot_delay is None:
            self.boot()
        else:
            self.power_on_when_asked(self.behaviour.boot_delay, lock or threading.Lock())

    # --- power-on state ---

    def on_reset(self) -> None:
        self.machine = DeviceStateMachine()
        self.absolute = self.config.homing == HOMING_ABSOLUTE
        self.homed = self.absolute
        self.zero = self.config.offset if self.absolute else -self.gain * self.x  # incremental: 0 here
        self.controlword = 0
        self.mode, self.mode_display = Mode.NONE, Mode.NONE
        self._mode_due: float | None = None
        self.target, self.torque = self.counts(), 0
        self.hold_at = self.x
        self.run: HomingRun | None = None
        self.error_code, self.error_register = 0, 0
        self.following_since: float | None = None
        self.blocked = False
        self.digital_inputs, self.digital_outputs = 0, 0

    @property
    def homing(self) -> bool:
        """A homing run drives the axis (at the homing speed)."""
        return self.run is not None and self.run.moving

    def counts(self, x: float | None = None) -> int:
        return int(round(self.gain * (self.x if x is None else x) + self.zero))

    def length(self, counts: int) -> float:
        return (counts - self.zero) / self.gain

    # --- object dictionary ---

    def process_value(self, index: int, subindex: int) -> Any:
        self._update_mode(time.monotonic())
        computed = self._computed.get(index)
        if computed is not None:
            return computed()
        if self.behaviour.fixed_pdos and any(index in r for r in _PDO_MAPPINGS):
            return self.node.object_dictionary[index][subindex].default  # its own, whatever was written
        return None

    def on_write(self, index: int, subindex: int, value: Any) -> None:
        b = self.behaviour
        if index in b.refuse or (index == 0x6060 and value not in b.modes) or \
                (index == 0x6098 and value not in b.homing_methods):
            raise SdoAbortedError(VALUE_RANGE_EXCEEDED)
        if index == 0x6040:
            self._on_controlword(int(value))
        elif index == 0x6060:
            self.mode = Mode(value) if value in Mode._value2member_map_ else Mode.NONE
            self._mode_due = time.monotonic() + b.mode_delay
            self._update_mode(time.monotonic())
        elif index == 0x607A:
            self.target = int(value)
        elif index == 0x6071:
            self.torque = int(value)
        elif index == 0x60FE and subindex == 1:
            self.digital_outputs = int(value)

    def _torque_actual(self) -> int:
        rated = self.value(0x6076) / 1000.0  # mN -> N
        return int(round(1000.0 * self.applied_force * math.copysign(1.0, self.gain) / rated)) if rated else 0

    def _update_mode(self, now: float) -> None:
        """The requested mode takes effect once its delay is over (0x6061 shows it)."""
        if self._mode_due is None or now < self._mode_due:
            return
        self._mode_due = None
        if self.mode is self.mode_display:
            return
        self.mode_display = self.mode
        self.run = None
        if self.machine.enabled:
            self.target = self.counts()  # the new mode starts where the axis is

    # --- state machine ---

    def _on_controlword(self, word: int) -> None:
        before = self.machine.state
        if before is State.FAULT and word & Controlword.FAULT_RESET:
            self.error_code, self.error_register = 0, 0
        state = self.machine.on_controlword(word)
        if before is State.FAULT and state is not State.FAULT and not self.silent:
            self.node.emcy.reset()  # EMCY "error reset"
        if state is State.OPERATION_ENABLED and before is not State.OPERATION_ENABLED:
            self.target = self.counts()          # enabled where it is
            self.following_since = None
        if state is not State.OPERATION_ENABLED:
            self.hold_at = self.x if before is State.OPERATION_ENABLED else self.hold_at
            self.run = None if self.run is not None and self.run.phase is not Phase.DONE else self.run
        rising = word & Controlword.HOMING_START and not self.controlword & Controlword.HOMING_START
        falling = self.controlword & Controlword.HOMING_START and not word & Controlword.HOMING_START
        if state is State.OPERATION_ENABLED and self.mode_display is Mode.HOMING:
            if rising:
                self._start_homing()
            elif falling and self.run is not None and self.run.phase is not Phase.DONE:
                self.run = None  # bit 4 dropped: homing interrupted
        self.controlword = word

    def _start_homing(self) -> None:
        self.homed = self.absolute
        self.run = HomingRun(self.value(0x6098), self.x, self.gain, self.stroke,
                             switches=self.behaviour.limit_switches, index_pitch=self.behaviour.index_pitch)
        if self.run.home is not None:
            self._take_home(self.run.home)

    def _take_home(self, home: float) -> None:
        """The home point is ``home`` [m]: there the count becomes 0x607C's."""
        self.zero = self.value(0x607C) - self.gain * home
        self.homed = True

    def statusword(self) -> int:
        extra = 0
        if self.machine.enabled:
            if self.mode_display is Mode.HOMING:
                extra |= self._homing_bits()
            elif self.mode_display is Mode.CYCLIC_SYNCHRONOUS_POSITION:
                extra |= Statusword.MODE_SPECIFIC_12
                extra |= Statusword.TARGET_REACHED if abs(self.target - self.counts()) <= 1 else 0
            else:
                extra |= Statusword.MODE_SPECIFIC_12
        if self.error_code == EMCY_CODES['following_error'][0]:
            extra |= Statusword.MODE_SPECIFIC_13
        lo, hi = self._limits()
        if self.machine.enabled and not lo <= self.target <= hi:
            extra |= Statusword.INTERNAL_LIMIT
        return self.machine.statusword(extra)

    def _homing_bits(self) -> int:
        """Bits 13 (error), 12 (attained), 10 (target reached) in homing mode (CiA 402)."""
        attained, error, reached = Statusword.MODE_SPECIFIC_12, Statusword.MODE_SPECIFIC_13, Statusword.TARGET_REACHED
        phase = None if self.run is None else self.run.phase
        if phase is None:  # not started or interrupted (a drive keeps "attained" from an earlier run)
            return reached | (attained if self.homed and not self.absolute else 0)
        return {Phase.SEEKING: 0, Phase.LEAVING: 0, Phase.STOPPING: attained, Phase.DONE: attained | reached,
                Phase.FAILED: error | reached}[phase]

    def _limits(self) -> tuple[int, int]:
        """The software position limits (0x607D) [counts] in force now."""
        if not (self.homed or self.behaviour.limits_before_homing):
            return _INT32
        return self.value(0x607D, 1, _INT32[0]), self.value(0x607D, 2, _INT32[1])

    # --- one SYNC ---

    def reference(self) -> float:
        """Where the axis is driven to this period [m] (CSP, homing), or held."""
        m = self.machine
        if m.enabled and self.mode_display is Mode.CYCLIC_SYNCHRONOUS_POSITION:
            lo, hi = self._limits()
            return self.length(min(max(self.target, lo), hi))
        if m.enabled and self.mode_display is Mode.HOMING and self.run is not None:
            return self.run.target
        return self.hold_at if not m.enabled else self.x

    def homing_speed(self) -> float:
        """[m/s] of this homing phase: 0x6099 sub-index 1 towards a switch, 2 towards the index."""
        leaving = self.run is not None and self.run.phase is Phase.LEAVING
        return self.value(0x6099, 2 if leaving else 1) / abs(self.gain)

    def force(self) -> float:
        """The force [N] the drive applies this period (CST; 0 when not enabled)."""
        if not (self.machine.enabled and self.mode_display is Mode.CYCLIC_SYNCHRONOUS_TORQUE):
            return 0.0
        limit = self.value(0x6072)
        per_mille = max(-limit, min(limit, self.torque))
        return per_mille * self.value(0x6076) / 1e6 * math.copysign(1.0, self.gain)

    def sense(self, x: float, v: float, force: float, time: float) -> None:
        """The axis after this period: position [m], speed [m/s], force [N]; then the homing
        and following-error checks."""
        before = self.x
        self.x, self.v, self.applied_force = x, v, force
        self._update_mode(time)
        if not self.machine.enabled:
            return
        if self.mode_display is Mode.HOMING and self.run is not None:
            home = self.run.advance(before, x)
            if home is not None:
                self._take_home(home)
        elif self.mode_display is Mode.CYCLIC_SYNCHRONOUS_POSITION:
            self._watch_following_error(time)

    def _watch_following_error(self, time: float) -> None:
        window, timeout = self.value(0x6065, 0, 2**32 - 1), self.value(0x6066, 0, 0) / 1000.0
        if abs(self.target - self.counts()) <= window:
            self.following_since = None
            return
        if self.following_since is None:
            self.following_since = time
        if time - self.following_since >= timeout:
            self.inject('following_error')

    # --- faults ---

    def inject(self, kind: str) -> None:
        """A fault: ``current`` (EMCY and the fault bit), ``fault_bit`` (the fault bit, no EMCY),
        ``following_error`` (the drive's monitor tripped: EMCY 0x8611), ``blocked`` (an
        obstacle holds the axis back by twice its following-error window, the bus simulator
        moves it: the monitor trips)."""
        if kind == 'blocked':
            self.blocked = True
            return
        self.hold_at = self.x
        self.machine.fault()
        self.run = None
        if kind == 'fault_bit':
            self.error_code, self.error_register = 0x5530, 0x01  # no EMCY sent
            return
        self.error_code, self.error_register = EMCY_CODES[kind]
        self.emergency(self.error_code, self.error_register)

    def following_window(self) -> float:
        """The following-error window (0x6065) [m]."""
        return self.value(0x6065, 0, 2**32 - 1) / abs(self.gain)
