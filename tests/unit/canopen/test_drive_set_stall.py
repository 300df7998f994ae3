"""The heartbeat consumer of :class:`rrps_canopen.drive_set.DriveSet` and a stall of its own
process: after a cycle that came late, the frames that arrived meanwhile are still being read, so
a drive is judged lost only one heartbeat timeout later; a drive that stays silent is still lost.
Explicit clock values (``cycle(now)``), on a loopback bus of the test's own with no drive on it
(so no RPDO is mapped: the cycle's RPDOs are not sent; its SYNCs are)."""

from __future__ import annotations

import pytest

from rrps_canopen.cia402 import Mode
from rrps_canopen.drive import RemoteDrive
from rrps_canopen.drive_set import DriveSet
from rrps_canopen.loopback_bus import free_port
from rrps_description.geometry import load_robot
from rrps_hardware.interface import FaultKind

BUS = load_robot('pole_climber').bus


@pytest.fixture
def drives(monkeypatch):
    monkeypatch.setenv('RRPS_CAN_PORT', str(free_port()))
    monkeypatch.setattr(RemoteDrive, 'send_rpdos', lambda self: None)
    ds = DriveSet(BUS, Mode.CYCLIC_SYNCHRONOUS_POSITION)
    yield ds
    ds.close()


def hear(ds: DriveSet, t: float, names=None) -> None:
    """Every drive's (or the named ones') heartbeat and TPDO read at ``t``."""
    for d in ds.drives:
        if names is None or d.name in names:
            d.data.heartbeat_time = d.data.tpdo_time = t


def run(ds: DriveSet, t0: float, t1: float, silent=()) -> float:
    """Cycles every sync period from ``t0`` to ``t1``, every drive but ``silent`` heard each one."""
    t = t0
    while t < t1:
        hear(ds, t, [d.name for d in ds.drives if d.name not in silent])
        ds.cycle(t)
        t += ds.period
    return t


def lost(ds: DriveSet) -> set[str]:
    return {name for name, f in ds.faults.items() if f.kind is FaultKind.LOST_HEARTBEAT}


def test_a_stall_of_this_process_is_not_a_lost_heartbeat(drives):
    timeout = BUS.heartbeat_timeout
    t = run(drives, 100.0, 100.05)
    assert not drives.faults
    # This process stalls for 3 timeouts; on waking, the cycle runs while one drive's queued
    # frames have been read and the others' not yet.
    t += 3 * timeout
    first = drives.drives[0].name
    hear(drives, t - 0.001, [first])
    drives.cycle(t)
    assert not drives.faults, drives.faults  # before the grace, this latched five drives
    t = run(drives, t + drives.period, t + 2 * timeout)  # the frames are read: all heard again
    assert not drives.faults


def test_a_drive_silent_through_a_stall_is_lost_one_timeout_after_it(drives):
    timeout = BUS.heartbeat_timeout
    t = run(drives, 100.0, 100.05)
    silent = drives.drives[2].name
    t_stall_end = t + 3 * timeout
    t = run(drives, t_stall_end, t_stall_end + timeout - drives.period, silent=[silent])
    assert not drives.faults
    run(drives, t, t_stall_end + timeout + 3 * drives.period, silent=[silent])
    assert lost(drives) == {silent}


def test_without_a_stall_a_silent_drive_is_lost_after_the_heartbeat_timeout(drives):
    timeout = BUS.heartbeat_timeout
    t = run(drives, 100.0, 100.05)
    silent = drives.drives[4].name
    t_last = t - drives.period
    t = run(drives, t, t_last + timeout - drives.period, silent=[silent])
    assert not drives.faults
    run(drives, t, t_last + timeout + 3 * drives.period, silent=[silent])
    assert lost(drives) == {silent}
