"""The simulated robot's physical state survives its driver (rrps_sim.hardware_state)."""

from __future__ import annotations

import json
import threading

import pytest

import rrps_sim.hardware_state as hardware_state
from rrps_description.geometry import load_robot
from rrps_sim.hardware_state import HardwareState, StateFileError, StateFileWriter, load_state, save_state

POLE = load_robot('pole_climber')


def test_a_saved_state_is_read_back(tmp_path):
    path = tmp_path / 'robot.json'
    assert load_state(path, POLE) is None
    state = HardwareState(robot='pole_climber', lengths=tuple(POLE.home_lengths + 0.01),
                          grippers={'ring_a': True, 'ring_b': False})
    save_state(path, state)
    assert load_state(path, POLE) == state
    assert [p.name for p in tmp_path.iterdir()] == ['robot.json']  # no temporary left behind


@pytest.mark.parametrize('change, message', [
    (lambda d: d.update(robot='frame_climber'), 'not'),
    (lambda d: d.update(lengths=[0.9] * 6), 'outside the stroke'),
    (lambda d: d.update(lengths=[0.43] * 5), 'outside the stroke'),
    (lambda d: d.update(grippers={'ring_a': False, 'ring_b': False}), 'both grippers open'),
    (lambda d: d.update(rings=[0.1]), 'ring angles'),
    (lambda d: d.pop('grippers'), 'unreadable'),
])
def test_a_state_that_cannot_be_trusted_is_refused(tmp_path, change, message):
    path = tmp_path / 'robot.json'
    save_state(path, HardwareState(robot='pole_climber', lengths=tuple(POLE.home_lengths)))
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))
    with pytest.raises(StateFileError, match=message):
        load_state(path, POLE)
    path.write_text('{"robot": "pole_cl')  # a file cut short
    with pytest.raises(StateFileError, match='unreadable'):
        load_state(path, POLE)


def _state(dz: float, ring_b_closed: bool = True) -> HardwareState:
    return HardwareState(robot='pole_climber', lengths=tuple(POLE.home_lengths + dz),
                         grippers={'ring_a': True, 'ring_b': ring_b_closed})


def test_the_writer_thread_takes_blocking_writes_off_the_caller_and_keeps_the_newest(tmp_path, monkeypatch):
    """A file system that blocks (a journal commit under load) blocks the writer's thread only:
    submit returns at once, and once the disk is back the file holds the newest state."""
    path = tmp_path / 'robot.json'
    disk_back, writing = threading.Event(), threading.Event()
    written = []

    def slow_save(p, state):
        writing.set()
        assert disk_back.wait(10.0)
        written.append(state)
        save_state(p, state)

    monkeypatch.setattr(hardware_state, 'save_state', slow_save)
    writer = StateFileWriter(path)
    try:
        writer.submit(_state(0.00))
        assert writing.wait(10.0)  # the first write is stuck on the "disk"
        for k in range(1, 50):  # the loop goes on: every submit returns while the disk blocks
            writer.submit(_state(0.0002 * k, ring_b_closed=k % 2 == 0))
        assert not writer.flush(timeout=0.05)  # still blocked: flush says so rather than hang
        disk_back.set()
        assert writer.flush(timeout=10.0)
        assert written == [_state(0.00), _state(0.0002 * 49, ring_b_closed=False)]  # the first, then the newest
        assert load_state(path, POLE) == _state(0.0002 * 49, ring_b_closed=False)
        assert writer.written == 2 and writer.error is None
    finally:
        disk_back.set()
        assert writer.close(timeout=10.0)


def test_the_writer_reports_a_failed_write_and_recovers(tmp_path):
    blocked = tmp_path / 'not_a_dir'
    blocked.write_text('a file where the directory should be')
    writer = StateFileWriter(blocked / 'robot.json')
    writer.submit(_state(0.0))
    assert writer.flush(timeout=10.0)
    assert isinstance(writer.error, OSError) and writer.written == 0
    blocked.unlink()
    writer.submit(_state(0.001))
    assert writer.close(timeout=10.0)  # close writes what is pending
    assert writer.error is None and writer.written == 1
    assert load_state(blocked / 'robot.json', POLE) == _state(0.001)
    with pytest.raises(RuntimeError, match='closed'):
        writer.submit(_state(0.0))
