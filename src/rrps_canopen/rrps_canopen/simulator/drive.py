"""A simulated CiA 402 linear drive: the state machine, homing, CSP and CST, the following-error
monitor, EMCY, and the faults a test injects.

The drive does not move anything itself: on each SYNC the bus simulator
(:mod:`rrps_canopen.simulator.bus`) asks it for its axis' reference (:meth:`SimulatedDrive.reference`
in CSP and homing, :meth:`SimulatedDrive.force` in CST), steps the actuator model of ``rrps_sim``,
and hands the drive the axis' new position and speed (:meth:`SimulatedDrive.sense`), from which it
computes its statusword, actual values and faults before its TPDOs go out. The encoder of the
axis is the drive's: absolute (``counts = gain * length + offset``) or incremental (0 at power-on
until homed). Pure Python (canopen), no ROS import.
"""

from __future__ import annotations

import math
from typing import Any

import canopen
from rrps_canopen.cia402 import Controlword, DeviceStateMachine, Mode, State, Statusword
from rrps_canopen.simulator.node import SimulatedNode
from rrps_description.bus import HOMING_ABSOLUTE, DriveConfig

__all__ = ['SimulatedDrive', 'EMCY_CODES']

#: EMCY error codes (CiA 301 / 402) the simulator sends, and the error register bits with them.
EMCY_CODES = {
    'current': (0x2310, 0x03),          # continuous over-current: generic + current
    'following_error': (0x8611, 0x81),  # following error: generic + manufacturer
}
#: Homing methods the simulator knows: on the current position; to the retracted end (a switch there).
HOMING_HERE = (35, 37)
HOMING_RETRACTED = (17, 1)


class SimulatedDrive(SimulatedNode):
    """One leg's drive (see the module docstring). ``config`` is how the real drive is mounted
    (counts per metre, direction, offset); ``stroke`` the axis' physical ends [m]."""

    def __init__(self, network: canopen.Network, config: DriveConfig, eds: str, stroke: tuple[float, float],
                 position: float):
        self.config, self.stroke = config, stroke
        self.gain = config.direction * config.counts_per_metre
        self.x, self.v, self.applied_force = position, 0.0, 0.0
        super().__init__(network, config.node_id, eds)
        self.on_reset()
        self.boot()

    # --- power-on state ---

    def on_reset(self) -> None:
        self.machine = DeviceStateMachine()
        self.absolute = self.config.homing == HOMING_ABSOLUTE
        self.homed = self.absolute
        self.zero = self.config.offset if self.absolute else -self.gain * self.x  # incremental: 0 here
        self.controlword = 0
        self.mode, self.mode_display = Mode.NONE, Mode.NONE
        self.target, self.torque = self.counts(), 0
        self.hold_at = self.x
        self.homing = False
        self.homing_error = False
        self.error_code, self.error_register = 0, 0
        self.following_since: float | None = None
        self.blocked = False
        self.digital_inputs, self.digital_outputs = 0, 0

    def counts(self, x: float | None = None) -> int:
        return int(round(self.gain * (self.x if x is None else x) + self.zero))

    def length(self, counts: int) -> float:
        return (counts - self.zero) / self.gain

    # --- object dictionary ---

    def process_value(self, index: int, subindex: int) -> Any:
        values = {0x6041: self.statusword, 0x6064: self.counts, 0x606C: lambda: int(round(self.gain * self.v)),
                  0x6077: self._torque_actual, 0x6061: lambda: int(self.mode_display),
                  0x603F: lambda: self.error_code, 0x1001: lambda: self.error_register,
                  0x60F4: lambda: self.target - self.counts(), 0x60FD: lambda: self.digital_inputs}
        return values[index]() if index in values else None

    def on_write(self, index: int, subindex: int, value: Any) -> None:
        if index == 0x6040:
            self._on_controlword(int(value))
        elif index == 0x6060:
            self.mode = Mode(value) if value in Mode._value2member_map_ else Mode.NONE
        elif index == 0x607A:
            self.target = int(value)
        elif index == 0x6071:
            self.torque = int(value)
        elif index == 0x60FE and subindex == 1:
            self.digital_outputs = int(value)

    def _torque_actual(self) -> int:
        rated = self.value(0x6076) / 1000.0  # mN -> N
        return int(round(1000.0 * self.applied_force * math.copysign(1.0, self.gain) / rated)) if rated else 0

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
            self.mode_display = self.mode
            self.following_since = None
        if state is not State.OPERATION_ENABLED:
            self.hold_at = self.x if before is State.OPERATION_ENABLED else self.hold_at
            self.homing = False
        if (state is State.OPERATION_ENABLED and self.mode is Mode.HOMING and word & Controlword.HOMING_START
                and not self.controlword & Controlword.HOMING_START):
            self.homing, self.homing_error = True, False
            self.homed = self.absolute
        self.controlword = word

    def statusword(self) -> int:
        extra = 0
        if self.machine.enabled:
            if self.mode_display is Mode.HOMING:
                extra |= (Statusword.MODE_SPECIFIC_12 if self.homed and not self.homing else 0)
                extra |= Statusword.MODE_SPECIFIC_13 if self.homing_error else 0
                extra |= Statusword.TARGET_REACHED if not self.homing else 0
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

    def _limits(self) -> tuple[int, int]:
        return self.value(0x607D, 1), self.value(0x607D, 2)

    # --- one SYNC ---

    def reference(self) -> float:
        """Where the axis is driven to this period [m] (CSP, homing), or held."""
        m = self.machine
        if m.enabled and self.mode_display is Mode.CYCLIC_SYNCHRONOUS_POSITION:
            lo, hi = self._limits()
            return self.length(min(max(self.target, lo), hi))
        if m.enabled and self.homing and self.config.homing in HOMING_RETRACTED:
            return self.stroke[0]
        return self.hold_at if not m.enabled else self.x

    def homing_speed(self) -> float:
        """[m/s] while homing towards a switch."""
        return self.value(0x6099, 1) / abs(self.gain)

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
        self.x, self.v, self.applied_force = x, v, force
        if not self.machine.enabled:
            return
        if self.mode is not self.mode_display:
            self.mode_display = self.mode
            self.target = self.counts()
        if self.homing:
            self._home()
        elif self.mode_display is Mode.CYCLIC_SYNCHRONOUS_POSITION:
            self._watch_following_error(time)

    def _home(self) -> None:
        method = self.config.homing
        home = self.value(0x607C)
        if method in HOMING_HERE or (method in HOMING_RETRACTED and self.x <= self.stroke[0] + 1e-9):
            self.zero = home - self.gain * self.x
            self.homed, self.homing = True, False
            self.target = self.counts()
        elif method not in HOMING_RETRACTED:
            self.homing, self.homing_error = False, True

    def _watch_following_error(self, time: float) -> None:
        window, timeout = self.value(0x6065), self.value(0x6066) / 1000.0
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
        self.homing = False
        if kind == 'fault_bit':
            self.error_code, self.error_register = 0x5530, 0x01  # no EMCY sent
            return
        self.error_code, self.error_register = EMCY_CODES[kind]
        self.emergency(self.error_code, self.error_register)

    def following_window(self) -> float:
        """The following-error window (0x6065) [m]."""
        return self.value(0x6065) / abs(self.gain)
