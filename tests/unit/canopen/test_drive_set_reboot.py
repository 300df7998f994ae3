"""A rebooted drive and the cycle of :class:`rrps_canopen.drive_set.DriveSet`: while the drive is
configured again in the background (its PDOs mapped anew: ``map_pdos`` clears each map, then
fills it), the cycle sends no RPDO of it; and an error in a cycle does not end the SYNCs: it
latches a fault on every drive (they hold) and the cycle goes on. A CI run's cycle thread died on
the first (a reboot injected mid-climb): every drive then looked silent to the fault reset for
60 s. On a loopback bus of the test's own with no drive on it."""

from __future__ import annotations

import threading
import time

import pytest

from rrps_canopen import drive_set as drive_set_module
from rrps_canopen.cia402 import Mode
from rrps_canopen.drive import RemoteDrive
from rrps_canopen.drive_set import DriveSet
from rrps_canopen.loopback_bus import free_port
from rrps_description.geometry import load_robot
from rrps_hardware.interface import FaultKind
from rrps_testing.ros_harness import wait_for

BUS = load_robot('pole_climber').bus


@pytest.fixture
def sent(monkeypatch):
    """The names of the drives whose RPDOs each call sent, in order."""
    names: list[str] = []
    monkeypatch.setattr(RemoteDrive, 'send_rpdos', lambda self: names.append(self.name))
    return names


@pytest.fixture
def drives(monkeypatch):
    monkeypatch.setenv('RRPS_CAN_PORT', str(free_port()))
    ds = DriveSet(BUS, Mode.CYCLIC_SYNCHRONOUS_POSITION)
    yield ds
    ds.close()


def hear(ds: DriveSet, t: float) -> None:
    for d in ds.drives:
        d.data.heartbeat_time = d.data.tpdo_time = t


def test_a_rebooted_drive_gets_no_rpdo_while_it_is_configured_again(drives, sent, monkeypatch):
    mapping, done = threading.Event(), threading.Event()

    def reconfigure(d, **_):   # stands for the SDO transfers of the mapping, held open by the test
        mapping.set()
        done.wait(10.0)
    monkeypatch.setattr(drive_set_module, 'reconfigure', reconfigure)
    rebooted = drives.drives[3]
    t = 100.0
    hear(drives, t)
    drives.cycle(t)
    assert sent == [d.name for d in drives.drives]
    rebooted.data.booted = True   # its boot-up message
    for _ in range(5):
        t += drives.period
        hear(drives, t)
        sent.clear()
        drives.cycle(t)
        assert rebooted.name not in sent and len(sent) == len(drives.drives) - 1, sent
    assert mapping.wait(5.0)
    assert drives.faults[rebooted.name].kind is FaultKind.REBOOTED
    done.set()
    assert wait_for(lambda: rebooted.name not in drives._rebooting)
    sent.clear()
    drives.cycle(t + drives.period)
    assert sent == [d.name for d in drives.drives]   # configured and started: its RPDOs again


def test_an_error_in_a_cycle_holds_every_drive_and_the_cycle_goes_on(drives, monkeypatch):
    calls = []

    def send_rpdos(self):
        calls.append(self.name)
        if len(calls) == 1:
            raise IndexError('list index out of range')   # a PDO map cleared meanwhile
    monkeypatch.setattr(RemoteDrive, 'send_rpdos', send_rpdos)
    hear(drives, time.monotonic() + 1.0)   # heard: the bus is not silent when the error comes
    thread = threading.Thread(target=drives._run)
    thread.start()
    try:
        assert wait_for(lambda: len(calls) > 10 * len(drives.drives)), 'the cycle stopped after the error'
    finally:
        drives._stop.set()
        thread.join(5.0)
    assert set(drives.faults) == {d.name for d in drives.drives}
    for fault in drives.faults.values():
        assert fault.kind is FaultKind.BUS_LOST
        assert fault.detail == "the CANopen cycle failed: IndexError('list index out of range')", fault
