"""What the viewer needs of viser beyond its public API, in one place, shaped as upstream would offer it.

Two hooks, a server's message producer and a client's connection, written on the internals of the pinned viser
(``viser.infra._infra``). tests/unit/viewer/test_viser_shim.py fails when viser changes under them; upgrading viser:
docs/viewer.md, "How the viewer works".
"""

from __future__ import annotations

import hashlib
import inspect

import viser
import viser.infra._infra as _infra

__all__ = ['VISER_VERSION', 'INTERNALS_SHA256', 'internals_digest', 'set_message_producer',
           'append_aligned_buffers', 'client_connection']

#: The viser version this shim was written against.
VISER_VERSION = '1.1.1'
#: viser's own message producer (kept before :func:`set_message_producer` replaces it).
_VISER_PRODUCER = _infra._message_producer
#: sha256 of the sources of the internals used here (:func:`internals_digest`).
INTERNALS_SHA256 = '8f1d263cc6427b1ccfd17b84cefda4c2553abd2f0cd8b60926aa698e17732120'


def internals_digest() -> str:
    """sha256 of the sources of viser's internals this module stands on: the message producer
    (the wire format a replacement must write), its buffer alignment, and the websocket server
    (where the producers and the connections live)."""
    digest = hashlib.sha256(viser.__version__.encode())
    for item in (_VISER_PRODUCER, _infra._append_aligned_buffers, _infra.WebsockServer):
        digest.update(inspect.getsource(item).encode())
    return digest.hexdigest()


def set_message_producer(producer) -> None:
    """Every viser server of this process sends each client's windows through ``producer``, a
    coroutine function ``producer(websocket, buffer, client_id, backlog_done_message=None)`` as
    viser's own ``_message_producer`` (upstream shape: a server's ``message_producer`` option)."""
    _infra._message_producer = producer


def append_aligned_buffers(parts: list, buffers: list, offset: int) -> None:
    """Append the binary ``buffers`` to ``parts``, each aligned to 8 bytes counted from the
    window's start (``offset``: the bytes already in ``parts``), as viser's wire format has them."""
    _infra._append_aligned_buffers(parts, buffers, offset)


def client_connection(server: viser.ViserServer, client_id: int):
    """The websocket connection (``websockets`` ServerConnection) of a connected client, None once
    it is gone (upstream shape: ``ClientHandle.connection``)."""
    return server._websock_server._live_connections.get(client_id)
