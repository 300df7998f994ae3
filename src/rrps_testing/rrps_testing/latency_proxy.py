"""A TCP proxy that adds latency, jitter or a stall to a connection (no ``netem`` needed).

    python -m rrps_testing.latency_proxy --listen 127.0.0.1:0 --target 127.0.0.1:8080 [--delay 50,150]

Each chunk read from either side is written to the other after a delay drawn uniformly from [lo, hi] ms, never
before the chunk before it (TCP keeps order). It prints ``{"listening": PORT}``, then reads one command a line
on stdin, each answered by a JSON line: ``delay LO HI`` (from now on; ``0 0``: none), ``stall SECONDS`` (hold
every chunk, queued ones too, that long), ``stats`` (chunks, bytes, connections, the longest delay
given and the longest a chunk went out late: the proxy's own stalls), ``quit``. Used by
tests/system/test_multihost_browser.py.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import random
import sys
import threading

__all__ = ['Shaper', 'main']

CHUNK = 65536


class Shaper:
    """The delay policy shared by every connection (changed at run time by the control)."""

    def __init__(self, lo_ms: float, hi_ms: float, seed: int | None = None):
        self.set_delay(lo_ms, hi_ms)
        self.hold_until = 0.0
        self.random = random.Random(seed)
        self.chunks = 0
        self.bytes = 0
        self.max_delay = 0.0
        self.max_late = 0.0      # the longest a chunk went out after its send time: the proxy's own stall
        self.connections = 0

    def set_delay(self, lo_ms: float, hi_ms: float) -> None:
        if not 0.0 <= lo_ms <= hi_ms:
            raise ValueError(f'delay needs 0 <= LO <= HI [ms], got {lo_ms}, {hi_ms}')
        self.lo, self.hi = lo_ms / 1e3, hi_ms / 1e3

    def send_time(self, now: float, previous: float) -> float:
        """When a chunk read at ``now`` goes out, after the one before it (sent at ``previous``)."""
        t = max(now + self.random.uniform(self.lo, self.hi), previous, self.hold_until)
        self.max_delay = max(self.max_delay, t - now)
        return t


async def _pump(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, shaper: Shaper) -> None:
    """Copy one direction: read chunks, release each at its send time, in order."""
    loop = asyncio.get_running_loop()
    queue: asyncio.Queue = asyncio.Queue()

    async def release() -> None:
        try:
            while True:
                at, data = await queue.get()
                delay = at - loop.time()
                if delay > 0:
                    await asyncio.sleep(delay)
                shaper.max_late = max(shaper.max_late, loop.time() - at)
                if data is None:
                    if writer.can_write_eof():
                        writer.write_eof()
                    return
                writer.write(data)
                await writer.drain()
                shaper.chunks += 1
                shaper.bytes += len(data)
        except (ConnectionError, OSError):
            return

    sender = asyncio.ensure_future(release())
    previous = 0.0
    try:
        while True:
            data = await reader.read(CHUNK)
            previous = shaper.send_time(loop.time(), previous)
            queue.put_nowait((previous, data or None))
            if not data:
                break
    except (ConnectionError, OSError):
        queue.put_nowait((previous, None))
    await sender


async def _serve(listen: tuple[str, int], target: tuple[str, int], shaper: Shaper,
                 stop: asyncio.Event) -> None:
    async def handle(client_reader, client_writer) -> None:
        shaper.connections += 1
        try:
            server_reader, server_writer = await asyncio.open_connection(*target)
        except OSError:
            client_writer.close()
            return
        try:
            await asyncio.gather(_pump(client_reader, server_writer, shaper),
                                 _pump(server_reader, client_writer, shaper))
        finally:
            for w in (client_writer, server_writer):
                w.close()

    server = await asyncio.start_server(handle, *listen)
    port = server.sockets[0].getsockname()[1]
    print(json.dumps({'listening': port}), flush=True)
    async with server:
        await stop.wait()


def _control(line: str, shaper: Shaper, loop, stop: asyncio.Event) -> dict:
    words = line.split()
    if not words:
        return {'ok': False, 'error': 'empty command'}
    cmd, args = words[0], words[1:]
    try:
        if cmd == 'delay' and len(args) == 2:
            shaper.set_delay(float(args[0]), float(args[1]))
            return {'ok': True, 'delay_ms': [shaper.lo * 1e3, shaper.hi * 1e3]}
        if cmd == 'stall' and len(args) == 1:
            shaper.hold_until = loop.time() + float(args[0])
            return {'ok': True, 'stall_s': float(args[0])}
        if cmd == 'stats' and not args:
            return {'ok': True, 'chunks': shaper.chunks, 'bytes': shaper.bytes,
                    'connections': shaper.connections, 'max_delay_s': shaper.max_delay,
                    'max_late_s': shaper.max_late}
        if cmd == 'quit':
            stop.set()
            return {'ok': True}
    except ValueError as exc:
        return {'ok': False, 'error': str(exc)}
    return {'ok': False, 'error': f'unknown command {line.strip()!r}'}


def _address(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(':')
    return host or '127.0.0.1', int(port)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--listen', type=_address, default=('127.0.0.1', 0), help='HOST:PORT to accept on')
    p.add_argument('--target', type=_address, required=True, help='HOST:PORT to forward to')
    p.add_argument('--delay', default='0,0', help='per-chunk delay range LO,HI [ms] (default 0,0)')
    p.add_argument('--seed', type=int, default=None, help='seed of the delay draws')
    args = p.parse_args(argv)
    lo, hi = (float(v) for v in args.delay.split(','))
    shaper = Shaper(lo, hi, args.seed)
    loop = asyncio.new_event_loop()
    stop = asyncio.Event()

    def control() -> None:  # stdin in a thread; each command runs on the event loop
        for line in sys.stdin:
            done = threading.Event()
            answer: dict = {}

            def run(line=line) -> None:
                answer.update(_control(line, shaper, loop, stop))
                done.set()
            loop.call_soon_threadsafe(run)
            done.wait()
            print(json.dumps(answer), flush=True)
        loop.call_soon_threadsafe(stop.set)  # stdin closed: the controller is gone

    threading.Thread(target=control, daemon=True).start()
    try:
        loop.run_until_complete(_serve(args.listen, args.target, shaper, stop))
    except KeyboardInterrupt:
        pass
    finally:
        loop.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
