"""A virtual CAN bus between the processes of this machine only: python-can interface ``rrps_loopback``.

``udp_multicast``'s idea kept on the host: the group joined and sent through 127.0.0.1 with TTL 0,
so no frame leaves the machine. A process does not receive its own frames (on Linux a BPF socket
filter drops them in the kernel). ``can.Bus(interface='rrps_loopback', channel=GROUP, port=PORT)``.
"""

from __future__ import annotations

import ctypes
import ipaddress
import select
import socket
import struct
import sys
import time
from typing import Any

import can
from can.interfaces.udp_multicast.utils import pack_message, unpack_message

__all__ = ['LoopbackBus', 'DEFAULT_GROUP', 'DEFAULT_PORT', 'free_port']

DEFAULT_GROUP = '239.74.163.10'
DEFAULT_PORT = 43120
LOOPBACK = '127.0.0.1'
_MAX_DATAGRAM = 4096
#: [bytes] the receive buffer asked for (the kernel caps it at net.core.rmem_max): about half a
#: second of a six-drive bus at 500 Hz, every process' own frames included. The default (about
#: 200 kB, 30 ms of that traffic) overflowed while a loaded machine stopped a process for 50 ms.
RECEIVE_BUFFER = 4 << 20


#: setsockopt option of a classic BPF socket filter (Linux' SO_ATTACH_FILTER).
SO_ATTACH_FILTER = 26


def _drop_own_datagrams(sock: socket.socket, port: int) -> ctypes.Array | None:
    """Attach a socket filter to ``sock`` that drops UDP datagrams from source port ``port``
    (Linux; the program's buffer is returned: keep it alive with the socket). None elsewhere."""
    if not sys.platform.startswith('linux'):
        return None
    program = [(0x28, 0, 0, 0),             # ldh [0]: the UDP source port
               (0x15, 0, 1, port),          # jeq #port, then drop, else accept
               (0x06, 0, 0, 0),             # ret #0: drop
               (0x06, 0, 0, 0xFFFFFFFF)]    # ret #-1: the whole datagram
    code = ctypes.create_string_buffer(b''.join(struct.pack('HBBI', *op) for op in program))
    sock.setsockopt(socket.SOL_SOCKET, SO_ATTACH_FILTER, struct.pack('HL', len(program), ctypes.addressof(code)))
    return code


def free_port() -> int:
    """A UDP port nothing on 127.0.0.1 uses now (a bus of its own for a demo or a test)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((LOOPBACK, 0))
        return s.getsockname()[1]


def _group(channel: Any) -> str:
    try:
        address = ipaddress.IPv4Address(str(channel))
    except ValueError:
        raise can.CanInitializationError(f'rrps_loopback: channel must be an IPv4 multicast group, '
                                         f'got {channel!r}') from None
    if not address.is_multicast:
        raise can.CanInitializationError(f'rrps_loopback: {channel} is not a multicast group (224.0.0.0/4)')
    return str(address)


class LoopbackBus(can.BusABC):
    """CAN frames as UDP multicast datagrams on the loopback interface (see the module docstring)."""

    def __init__(self, channel: Any = DEFAULT_GROUP, port: int = DEFAULT_PORT, receive_own_messages: bool = False,
                 **kwargs: Any):
        self.group, self.port = _group(channel), int(port)
        self.receive_own_messages = bool(receive_own_messages)
        self._rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self._rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            self._rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
            self._rx.bind((self.group, self.port))  # only this group's datagrams
            membership = socket.inet_aton(self.group) + socket.inet_aton(LOOPBACK)
            self._rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
            self._tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(LOOPBACK))
            self._tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
            self._tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
            self._tx.bind((LOOPBACK, 0))
        except OSError as exc:
            self._rx.close()
            self._tx.close()
            raise can.CanInitializationError(f'rrps_loopback: cannot open {self.group}:{self.port}: {exc}') from exc
        self._own = self._tx.getsockname()
        self._filter = None if self.receive_own_messages else _drop_own_datagrams(self._rx, self._own[1])
        self._destination = (self.group, self.port)
        self.channel_info = f'rrps_loopback {self.group}:{self.port}'
        super().__init__(channel=self.group, **kwargs)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if msg.is_fd:
            raise can.CanOperationError('rrps_loopback carries classic CAN frames only')
        if not msg.timestamp:
            msg.timestamp = time.time()
        try:
            self._tx.sendto(pack_message(msg), self._destination)
        except OSError as exc:
            raise can.CanOperationError(f'rrps_loopback: send failed: {exc}') from exc

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        try:
            ready, _, _ = select.select([self._rx], [], [], timeout)
            if not ready:
                return None, False
            data, sender = self._rx.recvfrom(_MAX_DATAGRAM)
        except (OSError, ValueError) as exc:  # closed by shutdown
            raise can.CanOperationError(f'rrps_loopback: receive failed: {exc}') from exc
        if sender == self._own and not self.receive_own_messages:
            return None, False
        try:
            msg = unpack_message(data, replace={'timestamp': time.time()}, check=True)
        except Exception:  # noqa: BLE001 - not a frame of this bus: dropped, as a controller drops noise
            return None, False
        return msg, False

    def fileno(self) -> int:
        return self._rx.fileno()

    def shutdown(self) -> None:
        super().shutdown()
        for sock in (self._rx, self._tx):
            try:
                sock.close()
            except OSError:
                pass

    @staticmethod
    def _detect_available_configs() -> list[dict]:
        return [{'interface': 'rrps_loopback', 'channel': DEFAULT_GROUP}]
