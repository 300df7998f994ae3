"""Faults of the grippers' I/O and of the CAN controller, against simulated drives (real
processes, real CANopen traffic on a loopback bus of the test's own): a clamp sensor that sticks
open under a closed clamp, and a bus-off reported by an error frame. Each time the driver holds,
reports which device and why (ERROR on /diagnostics, DriverStatus.faults), switches no gripper
output, and works again after the operator's fault reset and activation. ``-s`` prints each
episode (the fault table of docs/connecting-a-robot.md)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from rrps_description.geometry import robot_path
from rrps_interfaces.driver import gripper_states
from rrps_testing.canopen_stack import activated_driver, fault_episode
from rrps_testing.ros_harness import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.exclusive]  # the drive simulator and driver at SCHED_RR
#: [s] the test robot's ``bus.grippers.sensor_timeout``: room for the interlock's check before
#: the disagreement becomes a fault, on a loaded machine.
SENSOR_TIMEOUT = 2.0
ERROR = 2


def robot_yaml(tmp_path: Path) -> str:
    """The pole climber with a longer clamp sensor timeout, as a YAML file."""
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['bus']['grippers']['sensor_timeout'] = SENSOR_TIMEOUT
    path = tmp_path / 'pole_climber_sensor.yaml'
    path.write_text(yaml.safe_dump(data))
    return str(path)


def closed(rig, ring: str) -> bool | None:
    """The ring's clamp sensor as the driver's grippers/state last reported it."""
    if not rig.probe.grippers:
        return None
    state = gripper_states(rig.probe.grippers[-1][1].name, rig.probe.grippers[-1][1].position)
    return None if state is None else state[ring]


def test_a_stuck_clamp_sensor_is_a_fault_and_the_interlock_reads_the_sensor(tmp_path, ros_context, ros_domain_id):
    with activated_driver(ros_context, ros_domain_id, robot=robot_yaml(tmp_path)) as rig:
        sim, probe = rig.sim, rig.probe
        outputs = sim.status()['io']['outputs']
        assert outputs == 0 and wait_for(lambda: closed(rig, 'ring_a') and closed(rig, 'ring_b'))

        # ring_a's clamp stays closed (commanded closed), its sensor reads open
        t_stuck = sim.ask(cmd='sensor', ring='ring_a', stuck=False)['time']
        assert wait_for(lambda: closed(rig, 'ring_a') is False)
        success, message = probe.set_gripper('ring_b', False)
        assert not success and 'ring_a reads open on its sensor' in message, message
        assert sim.status()['grippers'] == {'ring_a': True, 'ring_b': True}

        # after the sensor timeout: a fault of ring_a's gripper; the driver goes inactive
        def reported():
            latest = probe.latest()
            return latest if latest[1] == ERROR and 'ring_a_gripper:gripper_sensor' in latest[3].faults else None
        assert wait_for(reported, timeout=60)
        first = next(t for t, level, _, status in list(probe.statuses)
                     if level == ERROR and 'ring_a_gripper:gripper_sensor' in status.faults)
        assert first - t_stuck >= SENSOR_TIMEOUT
        assert wait_for(lambda: not probe.latest()[3].active)
        assert not probe.set_gripper('ring_b', False)[0]

        # no reset (nor activation) while the sensor still disagrees with the command
        success, message = probe.reset_faults()
        assert not success and 'clamp sensor of ring_a disagrees' in message, message
        assert not probe.activate()
        assert 'ring_a_gripper:gripper_sensor' in probe.latest()[3].faults

        # the sensor agrees again: reset, activate, and the interlock lets ring_b open
        sim.ask(cmd='sensor', ring='ring_a', stuck=None)
        assert wait_for(lambda: probe.reset_faults()[0], period=0.2)
        assert probe.activate()
        assert wait_for(lambda: probe.latest()[3].active and not probe.latest()[3].faults)
        assert sim.status()['io']['outputs'] == outputs  # no output switched through the fault
        print(f'\n  clamp sensor stuck open: reported after {(first - t_stuck) * 1e3:.0f} ms '
              f'(sensor_timeout {SENSOR_TIMEOUT * 1e3:.0f} ms), 0 gripper switches, reset refused while it '
              'disagreed; reset, activate: OK', flush=True)
        assert probe.set_gripper('ring_b', False)[0]
        assert wait_for(lambda: closed(rig, 'ring_b') is False and sim.status()['grippers']['ring_b'] is False)
        assert probe.set_gripper('ring_b', True)[0]
        assert wait_for(lambda: closed(rig, 'ring_b'))


def test_a_bus_off_error_frame_holds_every_drive_until_reset(ros_context, ros_domain_id):
    with activated_driver(ros_context, ros_domain_id) as rig:
        episode = fault_episode(rig, 'bus_off', 'leg_1')
        print(f'\n  bus-off: reported after {episode.report_delay * 1e3:.0f} ms, held '
              f'{episode.time_to_hold * 1e3:.0f} ms after it, moved {episode.motion * 1e3:.2f} mm, '
              f'{episode.gripper_switches} gripper switches, "{episode.report}", recovered: {episode.recovered} '
              f'({episode.reset_message})', flush=True)
        assert 'bus-off' in episode.report, episode
        assert episode.gripper_switches == 0 and episode.motion < 1e-6, episode
        assert episode.recovered, episode
        status = rig.probe.latest()[3]
        assert status.active and not status.faults, status
