"""Switching the slave (one master, several robots): rrps_teleop.mapping.TeleopMapping.switch_slave."""

from __future__ import annotations

import numpy as np

from rrps_description.geometry import load_robot
from rrps_interfaces.teleop import TeleopCode
from rrps_teleop.mapping import TeleopConfig, TeleopMapping


def _engaged_mapping():
    slave, master = load_robot('pole_climber'), load_robot('master_robot')
    m = TeleopMapping(slave, TeleopConfig(), backend='numpy')
    t = 0.0
    m.on_slave_pose(slave.home_position, slave.home_quaternion_xyzw, t=t)
    m.set_driver_active(True)
    m.on_master_pose(t, master.home_position, master.home_quaternion_xyzw)
    m.on_enable(t, True)
    assert m.step(t).engaged
    return m, slave, master


def _tick(m, master, t, enable=True, slave=None):
    """The deadman and master at 20 Hz, the slave's pose (when given) at ``t``."""
    m.on_enable(t, enable)
    m.on_master_pose(t, master.home_position + [0.001, 0.0, 0.0], master.home_quaternion_xyzw)
    if slave is not None:
        m.on_slave_pose(slave.home_position + [0.0, 0.0, 0.01], slave.home_quaternion_xyzw, t=t)
    return m.step(t)


def test_a_deadman_held_through_a_switch_never_drives_the_new_robot():
    m, slave, master = _engaged_mapping()
    m.switch_slave()
    assert not m.engaged and m.command is None
    t = 0.0
    for _ in range(40):  # 2 s of a held deadman, the new robot's pose and driver coming in
        t += 0.05
        m.set_driver_active(True)
        out = _tick(m, master, t, slave=slave)
        assert not out.engaged and not out.has_command
        assert out.code is TeleopCode.DEADMAN_RELEASED and 'switched' in out.detail


def test_after_a_switch_the_deadman_counts_once_released_and_the_engage_is_a_clutch():
    m, slave, master = _engaged_mapping()
    m.switch_slave()
    t = 0.05
    assert _tick(m, master, t).code is TeleopCode.DEADMAN_RELEASED
    # no slave pose of the new robot yet: released and pressed again, it waits for one
    t += 0.05
    _tick(m, master, t, enable=False)
    t += 0.05
    assert _tick(m, master, t).code is TeleopCode.WAITING_FOR_SLAVE_POSE
    # its pose came, but not its driver's status: a known driver's status is awaited again
    t += 0.05
    assert _tick(m, master, t, slave=slave).code is TeleopCode.DRIVER_INACTIVE
    m.set_driver_active(True)
    t += 0.05
    out = _tick(m, master, t, slave=slave)
    assert out.engaged and out.has_command
    # the first command is the new robot's own pose: a clutch, no jump to where the old one was
    assert np.allclose(out.position, slave.home_position + [0.0, 0.0, 0.01], atol=1e-9)


def test_a_silent_deadman_after_a_switch_also_re_arms_it():
    m, slave, master = _engaged_mapping()
    m.switch_slave()
    t = 1.0  # no deadman sample for longer than enable_timeout: released
    m.set_driver_active(True)
    out = _tick(m, master, t, slave=slave)
    assert out.engaged
