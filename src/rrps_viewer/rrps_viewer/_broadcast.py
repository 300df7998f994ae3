"""Encode each viser window once for all the browsers that receive it.

viser runs one producer per websocket client, each serialising and compressing every window it sends. :func:`install`
replaces it (through :mod:`._viser_shim`) with one that encodes a window once, cached by the identity of its messages,
in viser's wire format byte for byte. A slow client only slows itself, and each connection's kernel send buffer is
bounded (``SEND_BUFFER_BYTES``) so a starved browser skips poses instead of queueing them (docs/viewer.md).
"""

from __future__ import annotations

import socket
import time
from collections import OrderedDict
from collections.abc import Sequence

import msgspec.msgpack
import zstandard

from rrps_viewer._viser_shim import append_aligned_buffers, set_message_producer

__all__ = ['EncodedWindows', 'install', 'windows_of']

#: Windows kept encoded: enough for clients a few windows apart.
CACHE_WINDOWS = 32
#: SO_SNDBUF of each browser connection (the kernel doubles it): with websockets' own 32 KiB,
#: at most about 0.1 MB (1 s of the viewer's stream) waits for a slow client; on a 300 ms link
#: (where teleop holds) it still carries about 200 kB/s, twice the stream.
SEND_BUFFER_BYTES = 32 * 1024


class EncodedWindows:
    """The wire bytes of the last ``size`` windows, by the identity of their messages.

    Entries hold their messages, so an id in a key is never reused while the entry lives.
    Used from its server's event-loop thread only (every producer of a server runs there).
    """

    def __init__(self, size: int = CACHE_WINDOWS):
        self._entries: OrderedDict[tuple[int, ...], tuple[tuple, bytes]] = OrderedDict()
        self._size = size
        self._zstd = zstandard.ZstdCompressor(level=1)
        self.encoded = 0
        self.shared = 0

    def get(self, window: Sequence) -> bytes:
        """The wire bytes of ``window`` (encoded now if no client was sent it yet)."""
        key = tuple(map(id, window))
        entry = self._entries.get(key)
        if entry is not None and all(a is b for a, b in zip(entry[0], window)):
            self._entries.move_to_end(key)
            self.shared += 1
            return entry[1]
        data = self._encode(window)
        self._entries[key] = (tuple(window), data)
        if len(self._entries) > self._size:
            self._entries.popitem(last=False)
        self.encoded += 1
        return data

    def _encode(self, window: Sequence) -> bytes:
        binary_buffers: list[memoryview] = []
        serialized = tuple(message.as_serializable_dict(binary_buffers) for message in window)
        inner = msgspec.msgpack.encode({'messages': serialized, 'timestampSec': time.perf_counter(),
                                        'binaryBufferLengths': tuple(b.nbytes for b in binary_buffers)})
        compressed = self._zstd.compress(inner)
        parts: list[bytes | memoryview] = [len(inner).to_bytes(8, 'little'),
                                           len(compressed).to_bytes(8, 'little'), compressed]
        append_aligned_buffers(parts, binary_buffers, 16 + len(compressed))
        return b''.join(parts)


def windows_of(buffer) -> EncodedWindows:
    """The window cache of one viser server, kept on its message buffer."""
    cache = getattr(buffer, 'rrps_encoded_windows', None)
    if cache is None:
        cache = buffer.rrps_encoded_windows = EncodedWindows()
    return cache


async def _shared_message_producer(websocket, buffer, client_id: int, backlog_done_message=None) -> None:
    """viser's producer loop, with each window's bytes from the server's :class:`EncodedWindows`."""
    window_generator = buffer.window_generator(client_id, backlog_done_message=backlog_done_message)
    cache = windows_of(buffer)
    sock = websocket.transport.get_extra_info('socket') if websocket.transport is not None else None
    if sock is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
    try:
        while not buffer.done:
            try:
                outgoing = await window_generator.__anext__()
            except StopAsyncIteration:
                break
            await websocket.send(cache.get(outgoing))
    finally:
        # As viser: close the generator now, so that its cursor and flush waiter go with it.
        await window_generator.aclose()


def install() -> None:
    """Make every viser server of this process encode a window once for all its clients."""
    set_message_producer(_shared_message_producer)
