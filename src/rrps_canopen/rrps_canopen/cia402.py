"""The CiA 402 (IEC 61800-7-201) power state machine: statusword, controlword, modes of operation.

Both sides use it: the backend picks the controlword one transition towards a wanted state
(:func:`controlword_toward`), the drive simulator runs the device (:class:`DeviceStateMachine`).
A fault reset is controlword bit 7's rising edge. Pure Python.
"""

from __future__ import annotations

import enum

__all__ = ['State', 'Mode', 'Controlword', 'Statusword', 'HomingStatus', 'state_of', 'homing_status',
           'controlword_toward', 'DeviceStateMachine', 'ENABLE_PATH']


class State(enum.Enum):
    """The power states of a CiA 402 drive."""

    NOT_READY_TO_SWITCH_ON = 'not_ready_to_switch_on'
    SWITCH_ON_DISABLED = 'switch_on_disabled'
    READY_TO_SWITCH_ON = 'ready_to_switch_on'
    SWITCHED_ON = 'switched_on'
    OPERATION_ENABLED = 'operation_enabled'
    QUICK_STOP_ACTIVE = 'quick_stop_active'
    FAULT_REACTION_ACTIVE = 'fault_reaction_active'
    FAULT = 'fault'


class Mode(enum.IntEnum):
    """Modes of operation (0x6060) used here."""

    NONE = 0
    HOMING = 6
    CYCLIC_SYNCHRONOUS_POSITION = 8
    CYCLIC_SYNCHRONOUS_TORQUE = 10


class Controlword(enum.IntEnum):
    """Controlword (0x6040) commands and bits."""

    DISABLE_VOLTAGE = 0x00
    QUICK_STOP = 0x02
    SHUTDOWN = 0x06
    SWITCH_ON = 0x07           # also "disable operation" from OPERATION_ENABLED
    ENABLE_OPERATION = 0x0F
    FAULT_RESET = 0x80         # bit 7: a rising edge resets a fault
    HOMING_START = 0x10        # bit 4 in homing mode: start homing


class Statusword(enum.IntFlag):
    """Statusword (0x6041) bits."""

    READY_TO_SWITCH_ON = 1 << 0
    SWITCHED_ON = 1 << 1
    OPERATION_ENABLED = 1 << 2
    FAULT = 1 << 3
    VOLTAGE_ENABLED = 1 << 4
    QUICK_STOP = 1 << 5        # active low: 0 = quick stop active
    SWITCH_ON_DISABLED = 1 << 6
    WARNING = 1 << 7
    REMOTE = 1 << 9
    TARGET_REACHED = 1 << 10
    INTERNAL_LIMIT = 1 << 11
    MODE_SPECIFIC_12 = 1 << 12  # homing: attained; CSP/CST: the drive follows the target
    MODE_SPECIFIC_13 = 1 << 13  # homing: error; CSP: following error


class HomingStatus(enum.Enum):
    """What the statusword says in homing mode (bits 13 error, 12 attained, 10 target reached)."""

    IN_PROGRESS = 'in progress'                            # 0 0 0
    NOT_STARTED = 'interrupted or not started'             # 0 0 1
    ATTAINED = 'attained, not yet at rest'                 # 0 1 0
    COMPLETED = 'completed'                                # 0 1 1
    ERROR = 'error'                                        # 1 x x


#: (mask, value, state) of the statusword, CiA 402 table 30.
_STATES = (
    (0x4F, 0x00, State.NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, State.SWITCH_ON_DISABLED),
    (0x6F, 0x21, State.READY_TO_SWITCH_ON),
    (0x6F, 0x23, State.SWITCHED_ON),
    (0x6F, 0x27, State.OPERATION_ENABLED),
    (0x6F, 0x07, State.QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, State.FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, State.FAULT),
)
_BITS = {state: value for _, value, state in _STATES}

#: The states from SWITCH_ON_DISABLED to OPERATION_ENABLED, in order.
ENABLE_PATH = (State.SWITCH_ON_DISABLED, State.READY_TO_SWITCH_ON, State.SWITCHED_ON, State.OPERATION_ENABLED)


def state_of(statusword: int) -> State | None:
    """The state a statusword reports (None: not a valid CiA 402 combination)."""
    for mask, value, state in _STATES:
        if statusword & mask == value:
            return state
    return None


def homing_status(statusword: int) -> HomingStatus:
    """The homing status of a statusword; meaningful only while the drive shows homing mode
    (0x6061 = 6): in other modes bits 12 and 13 mean other things."""
    if statusword & Statusword.MODE_SPECIFIC_13:
        return HomingStatus.ERROR
    attained, reached = statusword & Statusword.MODE_SPECIFIC_12, statusword & Statusword.TARGET_REACHED
    if attained:
        return HomingStatus.COMPLETED if reached else HomingStatus.ATTAINED
    return HomingStatus.NOT_STARTED if reached else HomingStatus.IN_PROGRESS


def controlword_toward(state: State | None, wanted: State) -> int | None:
    """The controlword of the next transition from ``state`` towards ``wanted`` (one of
    SWITCH_ON_DISABLED, SWITCHED_ON, OPERATION_ENABLED); None when there (or, from FAULT, the
    fault must be reset first)."""
    if state is wanted:
        return None
    if state in (State.FAULT, State.FAULT_REACTION_ACTIVE, None, State.NOT_READY_TO_SWITCH_ON):
        return None
    if wanted is State.SWITCH_ON_DISABLED:
        return int(Controlword.DISABLE_VOLTAGE)
    if state is State.QUICK_STOP_ACTIVE:
        return int(Controlword.DISABLE_VOLTAGE)
    if wanted is State.SWITCHED_ON and state is State.OPERATION_ENABLED:
        return int(Controlword.SWITCH_ON)
    step = {State.SWITCH_ON_DISABLED: Controlword.SHUTDOWN, State.READY_TO_SWITCH_ON: Controlword.SWITCH_ON,
            State.SWITCHED_ON: Controlword.ENABLE_OPERATION}
    return int(step[state]) if state in step else None


class DeviceStateMachine:
    """The device side: the state a drive is in, driven by controlwords and faults."""

    def __init__(self):
        self.state = State.SWITCH_ON_DISABLED
        self._reset_bit = False

    @property
    def enabled(self) -> bool:
        """Operation enabled: the drive follows its target."""
        return self.state is State.OPERATION_ENABLED

    def statusword(self, extra: int = 0) -> int:
        """The statusword of the state, with the mode-specific and other ``extra`` bits."""
        bits = _BITS[self.state]
        if self.state is not State.QUICK_STOP_ACTIVE and self.state not in (State.FAULT, State.FAULT_REACTION_ACTIVE,
                                                                            State.NOT_READY_TO_SWITCH_ON):
            bits |= Statusword.QUICK_STOP
        if self.state in (State.READY_TO_SWITCH_ON, State.SWITCHED_ON, State.OPERATION_ENABLED,
                          State.QUICK_STOP_ACTIVE):
            bits |= Statusword.VOLTAGE_ENABLED
        return int(bits) | Statusword.REMOTE | extra

    def fault(self) -> None:
        """A fault: through the fault reaction into FAULT (the drive is disabled)."""
        self.state = State.FAULT

    def on_controlword(self, word: int) -> State:
        """Apply a controlword (CiA 402 table 28); returns the new state."""
        reset_edge = bool(word & Controlword.FAULT_RESET) and not self._reset_bit
        self._reset_bit = bool(word & Controlword.FAULT_RESET)
        s = self.state
        if s is State.FAULT:
            if reset_edge:
                self.state = State.SWITCH_ON_DISABLED
            return self.state
        command = word & 0x0F
        if not command & 0x02:                                   # disable voltage (x x 0 x)
            self.state = State.SWITCH_ON_DISABLED
        elif not command & 0x04:                                 # quick stop (x 0 1 x)
            self.state = (State.QUICK_STOP_ACTIVE if s is State.OPERATION_ENABLED
                          else State.SWITCH_ON_DISABLED if s is not State.QUICK_STOP_ACTIVE else s)
        elif command & 0x0F == Controlword.SHUTDOWN:             # 0 1 1 0
            if s in (State.SWITCH_ON_DISABLED, State.SWITCHED_ON, State.OPERATION_ENABLED):
                self.state = State.READY_TO_SWITCH_ON
        elif command == Controlword.SWITCH_ON:                   # 0 1 1 1
            if s in (State.READY_TO_SWITCH_ON, State.OPERATION_ENABLED):
                self.state = State.SWITCHED_ON
        elif command == Controlword.ENABLE_OPERATION:            # 1 1 1 1
            if s in (State.SWITCHED_ON, State.QUICK_STOP_ACTIVE):
                self.state = State.OPERATION_ENABLED if s is State.SWITCHED_ON else s
        return self.state
