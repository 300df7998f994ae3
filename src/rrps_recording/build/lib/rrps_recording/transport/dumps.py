"""The flight recorder's dumps: each a bag folder ``<output_dir>/flight_<time>_<why>/`` of one
MCAP file (:func:`rrps_recording.storage.bag.write_bag`), written in a thread of its own, in
``<folder>.part`` renamed when complete, never over another. Pure: no rclpy."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path
from typing import Callable, Sequence

from rrps_recording.storage.bag import free_name, write_bag
from rrps_recording.storage.bag_metadata import TopicInfo

__all__ = ['FlightDumps']

Messages = Sequence[tuple[str, int, bytes]]


class FlightDumps:
    """Starts and tracks the dumps; ``on_error(text)`` reports one that could not be written."""

    def __init__(self, output_dir: str | os.PathLike, on_error: Callable[[str], None]):
        self.output_dir = Path(output_dir)
        self._on_error = on_error
        self.folders: list[Path] = []
        self._writers: list[threading.Thread] = []

    def _folder(self, why: str) -> Path:
        name = free_name(self.output_dir, f'flight_{time.strftime("%Y%m%d_%H%M%S")}_{why}',
                         taken={f.name for f in self.folders})
        return self.output_dir / name

    def start(self, why: str, messages: Callable[[], Messages], topics: Callable[[], list[TopicInfo]],
              *, settle: float = 0.0) -> Path:
        """Write ``messages()`` on ``topics()``, taken ``settle`` s from now, to a new bag;
        returns the path its MCAP file will have."""
        self.output_dir.mkdir(parents=True, exist_ok=True)
        folder = self._folder(why)
        self.folders.append(folder)

        def write() -> None:
            time.sleep(settle)
            try:
                write_bag(folder, topics(), messages())
            except OSError as exc:
                self._on_error(f'flight recorder: cannot write {folder}: {exc}')

        thread = threading.Thread(target=write, name='flight-recorder-dump', daemon=True)
        thread.start()
        self._writers = [w for w in self._writers if w.is_alive()] + [thread]
        return folder / f'{folder.name}_0.mcap'

    def wait(self, timeout: float = 30.0) -> None:
        """Wait until every dump started so far is written."""
        deadline = time.monotonic() + timeout
        for thread in list(self._writers):
            thread.join(max(0.0, deadline - time.monotonic()))
