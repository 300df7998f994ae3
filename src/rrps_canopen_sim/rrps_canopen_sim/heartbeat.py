"""The simulated devices' heartbeats (and any other periodic frame canopen asks for), from one
producer per bus, never behind the devices' PDOs: :meth:`HeartbeatProducer.send_due` runs on its
own thread and at each SYNC before the TPDOs (why: docs/tests.md). Pure Python (canopen, python-can)."""

from __future__ import annotations

import threading
import time

import can
import canopen

__all__ = ['HeartbeatProducer', 'PeriodicFrame']


class PeriodicFrame:
    """One periodic frame (canopen's ``PeriodicMessageTask`` interface: ``update``, ``stop``)."""

    def __init__(self, producer: 'HeartbeatProducer', can_id: int, data: bytes, period: float):
        self.producer, self.period = producer, period
        self.msg = can.Message(arbitration_id=can_id, data=bytes(data), is_extended_id=can_id > 0x7FF)
        self.due = time.monotonic()  # the first one at once (CiA 301: the producer starts at once)

    def update(self, data) -> None:
        self.msg = can.Message(arbitration_id=self.msg.arbitration_id, data=bytes(data),
                               is_extended_id=self.msg.is_extended_id)

    def stop(self) -> None:
        self.producer.remove(self)


class HeartbeatProducer:
    """The periodic frames of every device on ``network`` (its ``send_periodic``), sent by one
    thread when due and by :meth:`send_due` (at each SYNC, before the PDOs)."""

    def __init__(self, network: canopen.Network):
        self.network = network
        self.frames: list[PeriodicFrame] = []
        self.lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        network.send_periodic = self.add  # canopen's NMT producer starts and stops its heartbeat through it
        self._thread = threading.Thread(target=self._run, name='heartbeats', daemon=True)
        self._thread.start()

    def add(self, can_id: int, data, period: float, remote: bool = False) -> PeriodicFrame:
        frame = PeriodicFrame(self, can_id, data, period)
        with self.lock:
            self.frames.append(frame)
        self._wake.set()
        return frame

    def remove(self, frame: PeriodicFrame) -> None:
        with self.lock:
            if frame in self.frames:
                self.frames.remove(frame)

    def send_due(self, now: float | None = None) -> float:
        """Send every frame due by ``now``; the time the next one is due (inf: none)."""
        now = time.monotonic() if now is None else now
        with self.lock:
            due = [f for f in self.frames if f.due <= now]
            for f in due:  # a frame a period late goes out once, then on its period from now
                f.due = f.due + f.period if now - f.due < f.period else now + f.period
            upcoming = min((f.due for f in self.frames), default=float('inf'))
        for f in due:
            try:
                self.network.bus.send(f.msg)
            except (can.CanError, OSError, AttributeError):  # disconnected while closing
                pass
        return upcoming

    def _run(self) -> None:
        while not self._stop.is_set():
            upcoming = self.send_due()
            self._wake.wait(min(max(upcoming - time.monotonic(), 0.0), 0.2))
            self._wake.clear()

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join(timeout=1.0)
