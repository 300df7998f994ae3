"""The viewer encodes each viser window once for all browsers (rrps_teleop.viewer._broadcast)."""

import asyncio
import socket
import threading
import time

import msgspec
import numpy as np
import pytest
import viser
import websockets
import zstandard
from viser._messages import ViewerCameraMessage

from rrps_teleop.viewer._broadcast import EncodedWindows, install, windows_of


def decode(data: bytes) -> tuple[list[dict], bytes]:
    """viser's wire format: sizes, zstd msgpack, then the binary buffers."""
    size = int.from_bytes(data[0:8], 'little')
    compressed = int.from_bytes(data[8:16], 'little')
    inner = msgspec.msgpack.decode(zstandard.ZstdDecompressor().decompress(
        data[16:16 + compressed], max_output_size=size))
    return inner['messages'], data[16 + compressed:]


def camera() -> bytes:
    message = ViewerCameraMessage(wxyz=(1.0, 0.0, 0.0, 0.0), position=(1.0, 1.0, 1.0), fov=1.0,
                                  near=0.01, far=100.0, image_height=720, image_width=1280,
                                  look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0))
    return msgspec.msgpack.encode(message.as_serializable_dict())


def test_a_window_is_encoded_once_and_decodes_to_its_messages():
    cloud = viser._messages.PointCloudMessage(
        name='/cloud', props=viser._messages.PointCloudProps(
            points=np.arange(12, dtype=np.float32).reshape(4, 3), colors=np.zeros((4, 3), np.uint8),
            point_size=0.01, point_shape='circle', precision='float32', scale=1.0,
            point_shading='flat'))
    other = viser._messages.RemoveSceneNodeMessage(name='/gone')
    cache = EncodedWindows(size=2)
    first = cache.get([cloud, other])
    assert cache.get([cloud, other]) is first  # the same bytes object, not encoded again
    assert (cache.encoded, cache.shared) == (1, 1)
    messages, binary = decode(first)
    assert [m['name'] for m in messages] == ['/cloud', '/gone']
    assert np.arange(12, dtype=np.float32).tobytes() in binary  # the points, raw and aligned
    cache.get([other])
    cache.get([cloud])  # evicts [cloud, other]: at most two windows are kept
    assert cache.get([cloud, other]) is not first and cache.encoded == 4


def test_clients_of_a_server_share_the_encoding_and_all_see_every_pose():
    install()
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    server = viser.ViserServer(host='127.0.0.1', port=port, verbose=False)
    frame = server.scene.add_frame('/robot/ring_b', show_axes=False)
    received = [[] for _ in range(3)]
    ready = threading.Event()
    done = threading.Event()

    async def client(k: int) -> None:
        async with websockets.connect(f'ws://127.0.0.1:{port}', max_size=None,
                                      subprotocols=[f'viser-v{viser.__version__}']) as ws:
            await ws.send(camera())
            while not done.is_set():
                try:
                    data = await asyncio.wait_for(ws.recv(), timeout=0.2)
                except asyncio.TimeoutError:
                    continue
                for m in decode(data)[0]:
                    if m.get('type') == 'SetPositionMessage' and m.get('name') == '/robot/ring_b':
                        received[k].append(m['position'][0])

    def clients() -> None:
        async def go():
            tasks = [asyncio.create_task(client(k)) for k in range(3)]
            ready.set()
            await asyncio.gather(*tasks)
        asyncio.run(go())

    thread = threading.Thread(target=clients, daemon=True)
    thread.start()
    try:
        ready.wait(10)
        deadline = time.monotonic() + 20
        while len(server.get_clients()) < 3 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert len(server.get_clients()) == 3
        time.sleep(0.5)
        cache = windows_of(server._websock_server.get_message_buffer())
        before = (cache.encoded, cache.shared)
        for i in range(1, 41):  # 20 Hz, slower than viser's windows: one pose per window
            frame.position = (0.001 * i, 0.0, 0.0)
            time.sleep(0.05)
        time.sleep(0.5)
        encoded, shared = cache.encoded - before[0], cache.shared - before[1]
    finally:
        done.set()
        thread.join(10)
        server.stop()
    for poses in received:
        assert poses[-1] == pytest.approx(0.04)  # every client got the last pose
        assert len(poses) >= 10  # on a loaded machine a late client skips to the latest pose
    # A window is encoded for the first client that takes it and sent to the others from the
    # cache (2 shared per encoded when all three keep up; less when one falls behind).
    assert encoded >= 10 and shared >= encoded, (encoded, shared)
