"""Round trip to each browser, measured on its own websocket (the operator's network link).

Every ``period`` s a websocket Ping goes to each browser; its network stack answers whatever the page is busy with.
While a Ping is unanswered its age is a lower bound of the round trip, so a stalled link reads as slow at once. The
client's websocket comes from :func:`._viser_shim.client_connection`.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time

from rrps_viewer._viser_shim import client_connection

__all__ = ['LinkMonitor']


class LinkMonitor:
    """Round trip [s] per viser client id; :meth:`round_trip` reads it from any thread."""

    def __init__(self, server, *, period: float = 0.25):
        if not period > 0.0:
            raise ValueError(f'period must be > 0 s, got {period}')
        self._server = server
        self._period = period
        self._lock = threading.Lock()
        self._last: dict[int, float] = {}
        self._pending: dict[int, float] = {}
        loop = server.get_event_loop()
        self._task = asyncio.run_coroutine_threadsafe(self._run(), loop) if loop else None

    async def _ping(self, client_id: int, connection) -> None:
        with self._lock:
            if client_id in self._pending:
                return  # the previous Ping is still unanswered: its age tells
            self._pending[client_id] = time.monotonic()
        try:
            latency = await (await connection.ping())
        except Exception:  # the connection closed: the client is gone
            latency = math.inf
        with self._lock:
            self._pending.pop(client_id, None)
            self._last[client_id] = float(latency)

    async def _run(self) -> None:
        while True:
            live = {client_id: client_connection(self._server, client_id)
                    for client_id in self._server.get_clients()}
            live = {client_id: connection for client_id, connection in live.items() if connection is not None}
            with self._lock:
                for gone in set(self._last) - set(live):
                    self._last.pop(gone, None)
            for client_id, connection in live.items():
                asyncio.ensure_future(self._ping(client_id, connection))
            await asyncio.sleep(self._period)

    def round_trip(self, client_id: int) -> float | None:
        """The client's round trip [s]: the last answered Ping, or the age of an unanswered one
        if longer; None before the first answer."""
        with self._lock:
            last = self._last.get(client_id)
            pending = self._pending.get(client_id)
        waiting = None if pending is None else time.monotonic() - pending
        if last is None:
            return waiting if waiting is not None and waiting > self._period else None
        return max(last, waiting or 0.0)

    def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
