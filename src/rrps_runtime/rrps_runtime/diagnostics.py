"""A node's status on /diagnostics, with its typed values (:class:`rrps_interfaces.status.StatusValues`).

A status is named ``<node name>: <what>``, has a standard level and a ``hardware_id``: the robot's name, else the
host's role (:data:`OPERATOR_STATION`, :data:`OBSERVER`); see docs/recording.md, "/diagnostics_agg".
"""

from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from rrps_interfaces.status import DIAGNOSTICS, StatusValues, encode_value
from rrps_runtime.qos import STATE_QOS
from rrps_runtime.scheduling import process_scheduling

__all__ = ['OK', 'WARN', 'ERROR', 'STALE', 'LEVELS', 'OPERATOR_STATION', 'OBSERVER', 'Diagnostics', 'log_status']

OK = DiagnosticStatus.OK
WARN = DiagnosticStatus.WARN
ERROR = DiagnosticStatus.ERROR
STALE = DiagnosticStatus.STALE
#: The standard levels, the only ones a status may have.
LEVELS = (OK, WARN, ERROR, STALE)
#: hardware_id of the operator station's nodes (master, viewer, the Foxglove bridge).
OPERATOR_STATION = 'operator_station'
#: hardware_id of the observers (recorder, replay).
OBSERVER = 'observer'


class Diagnostics:
    """Publishes one DiagnosticStatus of a node on /diagnostics, at most ``rate_hz`` per second
    unless the level or message changes (so a rejection is reported at once)."""

    def __init__(self, node: Node, name: str, *, hardware_id: str, rate_hz: float = 2.0):
        if not hardware_id:
            raise ValueError(f'{node.get_name()}: a status needs a hardware_id (the robot or the host role)')
        self._node = node
        self._name = f'{node.get_name()}: {name}'
        self._hardware_id = hardware_id
        self._period = 1.0 / rate_hz
        self._pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS, STATE_QOS)
        self._last_key: tuple[bytes, str] | None = None
        self._last_time = -math.inf
        self.level = OK
        self.message = ''

    @property
    def name(self) -> str:
        """The status's name, ``<node name>: <what>``."""
        return self._name

    @property
    def hardware_id(self) -> str:
        return self._hardware_id

    def report(self, level: bytes, message: str, values: StatusValues | dict | None = None, *,
               force: bool = False) -> None:
        """Publish a status now if it changed, if forced, or if the period has elapsed.

        ``values``: the node's typed status (:class:`rrps_interfaces.status.StatusValues`),
        or a plain dict for values no other node reads. ValueError for a level that is not one
        of :data:`LEVELS`."""
        if level not in LEVELS:
            raise ValueError(f'not a diagnostic level: {level!r} (OK, WARN, ERROR or STALE)')
        self.level, self.message = level, message
        now = self._node.get_clock().now()
        t = now.nanoseconds * 1e-9
        key = (bytes(level), message)
        if not force and key == self._last_key and t - self._last_time < self._period:
            return
        self._last_key, self._last_time = key, t
        status = DiagnosticStatus(level=level, name=self._name, message=message,
                                  hardware_id=self._hardware_id)
        if isinstance(values, StatusValues):
            status.values = [KeyValue(key=k, value=v) for k, v in values.to_values().items()]
        else:
            status.values = [KeyValue(key=str(k), value=_format_value(v))
                             for k, v in (values or {}).items()]
        granted = process_scheduling()
        if granted is not None:  # the command path's scheduling (rrps_interfaces.status.SchedulingStatus)
            status.values += [KeyValue(key=k, value=encode_value(v)) for k, v in granted.values().items()]
        msg = DiagnosticArray()
        msg.header.stamp = now.to_msg()
        msg.status = [status]
        self._pub.publish(msg)


def log_status(logger, level: bytes, message: str) -> None:
    """Say a node's new status ``message`` of ``level`` in its ``logger``: an ERROR every time (a
    fault's reason must show), a WARN or STALE at most once a second (a status that flaps between
    two values), an OK not at all (/diagnostics has it)."""
    if level == ERROR:
        logger.error(message)
    elif level != OK:
        logger.warning(message, throttle_duration_sec=1.0)


def _format_value(value) -> str:
    if isinstance(value, float):
        return f'{value:.6g}'
    if isinstance(value, np.ndarray):
        return np.array2string(value, precision=6, separator=',', max_line_width=10_000)
    return str(value)
