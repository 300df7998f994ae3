"""When the flight recorder writes its buffer: the fault triggers, as one small pure function. No rclpy.

From typed values only (:class:`RecorderTrigger`): a node's /diagnostics at ERROR (``NODE_ERROR``), a rise of
``DriverStatus.gripper_refusals`` (``GRIPPER_REFUSAL``), ``teleop/status`` or ``climb/status`` at ERROR or at
STALE after OK or WARN (``LINK_LOST``; a status that starts STALE has lost nothing). :class:`FaultWatch` fires
once per fault, not at every repetition, and again after the source recovers; a new rule is a branch of
:meth:`FaultWatch.check`.
"""

from __future__ import annotations

import dataclasses

from rrps_interfaces.climb import CLIMB_STATUS
from rrps_interfaces.driver import DriverStatus
from rrps_interfaces.recording import RecorderTrigger
from rrps_interfaces.status import ContractError, source_node
from rrps_interfaces.teleop import TELEOP_STATUS

__all__ = ['OK', 'WARN', 'ERROR', 'STALE', 'StatusEvent', 'FaultWatch']

# diagnostic_msgs/DiagnosticStatus levels
OK, WARN, ERROR, STALE = 0, 1, 2, 3

DRIVER_NODE = 'driver_node'
LINK_TOPICS = (TELEOP_STATUS, CLIMB_STATUS)


@dataclasses.dataclass(frozen=True)
class StatusEvent:
    """One DiagnosticStatus as the recorder saw it: ``source`` is ``'/diagnostics'`` or the
    relative status topic (``teleop/status``, ``climb/status``)."""

    source: str
    level: int
    name: str
    values: dict[str, str]

    @classmethod
    def of(cls, source: str, status) -> StatusEvent:
        """The event of a diagnostic_msgs DiagnosticStatus (its level a byte or an int)."""
        level = status.level
        return cls(source, int.from_bytes(level, 'little') if isinstance(level, bytes) else int(level),
                   status.name, {kv.key: kv.value for kv in status.values})


class FaultWatch:
    """Turns status events into flight-recorder triggers (see the module docstring)."""

    def __init__(self):
        self._refusals: int | None = None
        self._faulted: set[str] = set()
        self._healthy: set[str] = set()

    def _edge(self, key: str, faulted: bool) -> bool:
        """True when ``key`` becomes faulted (not while it stays so)."""
        if not faulted:
            self._faulted.discard(key)
            return False
        if key in self._faulted:
            return False
        self._faulted.add(key)
        return True

    def check(self, event: StatusEvent) -> RecorderTrigger | None:
        """The trigger this event fires, or None."""
        if event.source in LINK_TOPICS:
            if event.level in (OK, WARN):
                self._healthy.add(event.source)
            lost = event.level == ERROR or (event.level == STALE
                                             and event.source in self._healthy)
            return RecorderTrigger.LINK_LOST if self._edge(event.source, lost) else None
        trigger = None
        if source_node(event.name) == DRIVER_NODE:
            try:
                refusals = DriverStatus.from_values(event.values).gripper_refusals
            except ContractError:
                refusals = None
            if refusals is not None:
                if self._refusals is not None and refusals > self._refusals:
                    trigger = RecorderTrigger.GRIPPER_REFUSAL
                self._refusals = refusals
        if self._edge(f'diag:{event.name}', event.level == ERROR) and trigger is None:
            trigger = RecorderTrigger.NODE_ERROR
        return trigger
