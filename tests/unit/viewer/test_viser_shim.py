"""The viewer's shim on viser's internals (rrps_viewer._viser_shim): it fails when viser
changes under it, and its hooks work on a live server."""

import asyncio
import socket
import time

import msgspec
import viser
import websockets
from viser._messages import ViewerCameraMessage

from rrps_viewer import _viser_shim
from rrps_viewer._broadcast import install
from rrps_viewer._viser_shim import INTERNALS_SHA256, VISER_VERSION, client_connection, internals_digest

CAMERA = ViewerCameraMessage(wxyz=(1.0, 0.0, 0.0, 0.0), position=(1.0, 1.0, 1.0), fov=1.0, near=0.01, far=100.0,
                             image_height=720, image_width=1280, look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0))


def test_viser_is_the_version_and_the_source_the_shim_was_written_against():
    """An upgrade of viser (or a change of the internals the shim stands on) must be deliberate:
    check the wire format and the two hooks against the new source, then update the shim."""
    assert viser.__version__ == VISER_VERSION
    assert internals_digest() == INTERNALS_SHA256
    install()                                   # the viewer's producer replaces viser's: the same digest
    assert internals_digest() == INTERNALS_SHA256


def test_a_client_connection_pings_and_is_gone_after_the_client():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    server = viser.ViserServer(host='127.0.0.1', port=port, verbose=False)
    try:
        async def visit() -> float:
            async with websockets.connect(f'ws://127.0.0.1:{port}',
                                          subprotocols=[f'viser-v{viser.__version__}']) as ws:
                await ws.send(msgspec.msgpack.encode(CAMERA.as_serializable_dict()))  # a browser's first message
                deadline = time.monotonic() + 20
                while not server.get_clients() and time.monotonic() < deadline:
                    await asyncio.sleep(0.05)
                (client_id,) = server.get_clients()
                connection = client_connection(server, client_id)
                pong = asyncio.run_coroutine_threadsafe(_ping(connection), server.get_event_loop())
                return await asyncio.wrap_future(pong), client_id

        latency, client_id = asyncio.run(visit())
        assert 0.0 <= latency < 5.0
        deadline = time.monotonic() + 20
        while client_connection(server, client_id) is not None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert client_connection(server, client_id) is None
    finally:
        server.stop()


async def _ping(connection) -> float:
    return await (await connection.ping())


def test_the_producer_hook_replaces_viser_s_producer():
    import viser.infra._infra as infra
    kept = infra._message_producer

    async def producer(websocket, buffer, client_id, backlog_done_message=None):
        return None

    try:
        _viser_shim.set_message_producer(producer)
        assert infra._message_producer is producer
    finally:
        _viser_shim.set_message_producer(kept)
