"""The loopback CAN bus: frames go between processes of this machine and never onto its network.

A raw capture (AF_PACKET, root) on every other interface sees none of the bus' datagrams while a
second process exchanges 2,000 frames with this one, and those interfaces' transmit counters
grow by less than the frames sent."""

from __future__ import annotations

import os
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import can
import pytest

from rrps_canopen.loopback_bus import free_port
from rrps_testing.ci import require

pytestmark = pytest.mark.slow
GROUP = '239.74.163.77'
FRAMES = 2000
ECHO = f"""
import can, sys
bus = can.Bus(interface='rrps_loopback', channel='{GROUP}', port=int(sys.argv[1]))
print('ready', flush=True)
for _ in range({FRAMES}):
    msg = bus.recv(timeout=30)
    if msg is None:
        break
    bus.send(can.Message(arbitration_id=msg.arbitration_id + 1, data=msg.data, is_extended_id=False))
bus.shutdown()
"""


def other_interfaces() -> list[str]:
    return [i for i in os.listdir('/sys/class/net') if i != 'lo']


def tx_packets(interface: str) -> int:
    return int(Path(f'/sys/class/net/{interface}/statistics/tx_packets').read_text())


class Capture:
    """Every IPv4 UDP datagram to the bus' group or port seen on ``interface`` (a raw socket)."""

    def __init__(self, interface: str, port: int):
        self.sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(0x0003))
        self.sock.bind((interface, 0))
        self.sock.settimeout(0.1)
        self.port, self.seen, self.packets = port, [], 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        group = socket.inet_aton(GROUP)
        while not self.stop.is_set():
            try:
                frame = self.sock.recv(65535)
            except socket.timeout:
                continue
            self.packets += 1
            if len(frame) < 14 + 28 or frame[12:14] != b'\x08\x00':
                continue
            ip = frame[14:]
            header = (ip[0] & 0x0F) * 4
            dport = struct.unpack('!H', ip[header + 2:header + 4])[0] if ip[9] == 17 else None
            if ip[16:20] == group or dport == self.port:
                self.seen.append(frame)

    def close(self) -> None:
        self.stop.set()
        self.thread.join()
        self.sock.close()


def test_the_loopback_bus_carries_frames_between_processes_and_none_leaves_the_machine():
    require(os.geteuid() == 0, 'a raw capture needs root')
    port = free_port()
    interfaces = [i for i in other_interfaces() if Path(f'/sys/class/net/{i}/operstate').read_text().strip() != 'down']
    captures = [Capture(i, port) for i in interfaces]
    before = {i: tx_packets(i) for i in interfaces}
    echo = subprocess.Popen([sys.executable, '-c', ECHO, str(port)], stdout=subprocess.PIPE, text=True)
    bus = can.Bus(interface='rrps_loopback', channel=GROUP, port=port)
    try:
        assert echo.stdout.readline().strip() == 'ready'
        answered = 0
        for k in range(FRAMES):
            bus.send(can.Message(arbitration_id=0x100, data=k.to_bytes(2, 'little'), is_extended_id=False))
            msg = bus.recv(timeout=10)
            assert msg is not None and msg.arbitration_id == 0x101, k   # its own frames never come back
            answered += int.from_bytes(msg.data, 'little') == k
        assert answered == FRAMES
        time.sleep(0.2)
    finally:
        bus.shutdown()
        echo.wait(timeout=30)
        for capture in captures:
            capture.close()
    for interface, capture in zip(interfaces, captures):
        assert not capture.seen, f'{len(capture.seen)} frames of the bus on {interface}'
        assert tx_packets(interface) - before[interface] < FRAMES, interface


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='the kernel filter is Linux only')
def test_a_bus_is_never_woken_by_its_own_frames():
    """Its own datagrams are dropped in the kernel (a socket filter): the bus' socket does not
    even become readable for them, as a CAN controller's host never sees its own frames."""
    import select
    port = free_port()
    one = can.Bus(interface='rrps_loopback', channel=GROUP, port=port)
    other = can.Bus(interface='rrps_loopback', channel=GROUP, port=port)
    try:
        for k in range(100):
            one.send(can.Message(arbitration_id=0x100, data=[k], is_extended_id=False))
        assert other.recv(timeout=10) is not None  # they went out
        readable, _, _ = select.select([one.fileno()], [], [], 0.3)
        assert not readable
        other.send(can.Message(arbitration_id=0x200, data=[1], is_extended_id=False))
        readable, _, _ = select.select([one.fileno()], [], [], 10.0)
        assert readable and one.recv(timeout=1).arbitration_id == 0x200
    finally:
        one.shutdown()
        other.shutdown()


def test_a_channel_that_is_not_a_multicast_group_is_refused():
    with pytest.raises(can.CanInitializationError, match='not a multicast group'):
        can.Bus(interface='rrps_loopback', channel='192.0.2.7', port=free_port())
