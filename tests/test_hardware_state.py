"""The simulated robot's physical state survives its driver (rrps_sim.hardware_state)."""

from __future__ import annotations

import json

import pytest

from rrps_kinematics import load_robot
from rrps_sim.hardware_state import HardwareState, StateFileError, load_state, save_state

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
