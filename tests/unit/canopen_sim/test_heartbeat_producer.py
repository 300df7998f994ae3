"""The drive simulator's heartbeat producer: canopen's NMT heartbeat goes through it, a frame
due is sent once (by its thread or at a SYNC), a frame a period late restarts its period, and a
stopped heartbeat is never sent again. Explicit clock values, no timing assertions."""

from __future__ import annotations

import time

import can
import canopen

from rrps_canopen.network import resolve_eds
from rrps_canopen_sim.heartbeat import HeartbeatProducer

HOUR = 3600.0  # [s] a period the producer's thread never reaches in a test


class RecordingBus:
    """A python-can bus stand-in that keeps what is sent."""

    def __init__(self):
        self.sent: list[can.Message] = []

    def send(self, msg: can.Message, timeout=None) -> None:
        self.sent.append(msg)


def network() -> canopen.Network:
    net = canopen.Network()
    net.bus = RecordingBus()
    return net


def wait_until(condition, timeout: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def test_canopen_nmt_heartbeat_goes_through_the_producer_and_follows_the_state():
    net = network()
    producer = HeartbeatProducer(net)
    try:
        node = canopen.LocalNode(3, resolve_eds('cia402_linear_drive.eds'))
        net.add_node(node)
        node.nmt.send_command(0x80)     # PRE-OPERATIONAL
        node.sdo[0x1017].raw = 20       # heartbeat producer time [ms]
        frames = [(f.msg.arbitration_id, bytes(f.msg.data), f.period) for f in producer.frames]
        assert frames == [(0x703, b'\x7f', 0.02)]
        node.nmt.send_command(0x01)     # OPERATIONAL: the heartbeat carries the new state
        assert bytes(producer.frames[0].msg.data) == b'\x05'
        assert wait_until(lambda: any(m.arbitration_id == 0x703 and m.data == b'\x05' for m in net.bus.sent))
        node.nmt.stop_heartbeat()
        assert producer.frames == []
        n = len(net.bus.sent)
        producer.send_due(time.monotonic() + HOUR)
        assert len(net.bus.sent) == n
    finally:
        producer.close()


def test_a_due_frame_goes_out_once_and_a_late_one_restarts_its_period():
    net = network()
    producer = HeartbeatProducer(net)
    try:
        frame = producer.add(0x705, [5], HOUR)
        assert wait_until(lambda: len(net.bus.sent) == 1)  # the first one at once, by the thread
        due = frame.due
        assert producer.send_due(due - 1.0) == due and len(net.bus.sent) == 1  # not due yet
        assert producer.send_due(due + 1.0) == due + HOUR and len(net.bus.sent) == 2  # on its period
        late = due + HOUR + 2 * HOUR
        producer.send_due(late)  # two periods late (a stalled process): once, then a period from now
        assert len(net.bus.sent) == 3 and frame.due == late + HOUR
        assert all(m.arbitration_id == 0x705 and m.data == b'\x05' for m in net.bus.sent)
    finally:
        producer.close()
