"""The flight recorder: the last ``buffer_seconds`` of the recorded messages in memory
(:class:`rrps_recording.transport.ring.MessageRing`) and their dumps
(:class:`rrps_recording.transport.dumps.FlightDumps`), one ``post_trigger`` s after a fault (so
that its aftermath is in), at most one every ``min_dump_interval`` s and one waiting at a time,
or at once on the operator's request. Which status is a fault: :mod:`rrps_recording.transport.triggers`.
Pure: no rclpy."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Callable

from rrps_interfaces.recording import RecorderTrigger
from rrps_recording.storage.bag_metadata import TopicInfo
from rrps_recording.transport.dumps import FlightDumps
from rrps_recording.transport.ring import MessageRing

__all__ = ['FlightRecorder']


class FlightRecorder:
    """The window (:attr:`ring`), the dumps (:attr:`dumps`) and when the next one is written;
    ``on_error(text)`` reports a dump that could not be written."""

    def __init__(self, output_dir: str | os.PathLike, on_error: Callable[[str], None], *,
                 buffer_seconds: float, max_bytes: int, post_trigger: float, min_dump_interval: float):
        self.ring = MessageRing(buffer_seconds, max_bytes=max_bytes)
        self.dumps = FlightDumps(output_dir, on_error)
        self.buffer_seconds = buffer_seconds
        self.post_trigger = post_trigger
        self.min_dump_interval = min_dump_interval
        self.last_trigger: RecorderTrigger | None = None
        self._pending: tuple[float, RecorderTrigger] | None = None
        self._last_dump_time = -1e18

    def schedule(self, trigger: RecorderTrigger, now: float) -> bool:
        """A fault at ``now`` (monotonic [s]): its dump is due ``post_trigger`` s later. False
        (nothing scheduled) while a dump waits or within ``min_dump_interval`` of the last one."""
        if self._pending is not None or now - self._last_dump_time < self.min_dump_interval:
            return False
        self._pending = (now + self.post_trigger, trigger)
        return True

    def due(self, now: float) -> RecorderTrigger | None:
        """The trigger of the scheduled dump once it is due at ``now`` (it is then no longer
        scheduled), else None."""
        pending = self._pending
        if pending is None or now < pending[0]:
            return None
        self._pending = None
        return pending[1]

    def dump(self, trigger: RecorderTrigger, topics: Callable[[], list[TopicInfo]], *,
             settle: float = 0.0) -> Path:
        """Write the window on ``topics()`` (in a thread, ``settle`` s from now) to a new bag
        folder; returns the path its MCAP file will have."""
        self._last_dump_time = time.monotonic()
        self.last_trigger = trigger
        return self.dumps.start(trigger.value, self.ring.snapshot, topics, settle=settle)

    def status_values(self) -> dict:
        """Its fields of recorder_node's status (:class:`rrps_interfaces.recording.RecorderStatus`)."""
        folders = self.dumps.folders
        return {'buffered_messages': len(self.ring), 'buffer_seconds': self.ring.span,
                'dumps': len(folders), 'last_dump': str(folders[-1]) if folders else '',
                'last_trigger': self.last_trigger}
