"""The flight recorder's memory: the last ``seconds`` of every recorded message at full rate, within ``max_bytes``.
:class:`MessageRing` keeps (topic, log time [ns], CDR bytes); :meth:`MessageRing.snapshot` copies the window out
while recording goes on. Thread-safe; no rclpy."""

from __future__ import annotations

import collections
import threading
from typing import Sequence

__all__ = ['MessageRing']


class MessageRing:
    """A time window of messages; see the module docstring."""

    def __init__(self, seconds: float = 60.0, *, max_bytes: int = 512 << 20):
        if not seconds > 0.0:
            raise ValueError(f'seconds must be > 0, got {seconds}')
        if max_bytes <= 0:
            raise ValueError(f'max_bytes must be > 0, got {max_bytes}')
        self.window_ns = int(seconds * 1e9)
        self.max_bytes = int(max_bytes)
        self._items: collections.deque = collections.deque()
        self._bytes = 0
        self._lock = threading.Lock()
        self.dropped_for_memory = 0

    def add(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Append a message and forget what fell out of the window."""
        self.add_many(((topic, log_time_ns, data),))

    def add_many(self, messages: Sequence[tuple[str, int, bytes]]) -> None:
        """Append messages (topic, log time [ns], CDR bytes) and forget what fell out of the
        window (measured from the last one)."""
        if not messages:
            return
        with self._lock:
            items = self._items
            items.extend(messages)
            self._bytes += sum(len(m[2]) for m in messages)
            log_time_ns = messages[-1][1]
            if items[0][1] < log_time_ns - self.window_ns:
                horizon = log_time_ns - self.window_ns
                while items and items[0][1] < horizon:
                    self._bytes -= len(items.popleft()[2])
            if self._bytes > self.max_bytes:
                while self._bytes > self.max_bytes and len(items) > 1:
                    self._bytes -= len(items.popleft()[2])
                    self.dropped_for_memory += 1

    def snapshot(self) -> list[tuple[str, int, bytes]]:
        """A copy of the window, oldest first."""
        with self._lock:
            return list(self._items)

    def __len__(self) -> int:
        return len(self._items)

    @property
    def nbytes(self) -> int:
        """Bytes of message data held."""
        return self._bytes

    @property
    def span(self) -> float:
        """Seconds between the oldest and the newest message held (0 when fewer than two)."""
        with self._lock:
            if len(self._items) < 2:
                return 0.0
            return (self._items[-1][1] - self._items[0][1]) * 1e-9
