"""The CANopen backend against simulated drives, real processes, real CANopen traffic on the
loopback bus: bring-up and homing of six drives, and a wrong EDS, node id or homing method refused
at configure (driver_node exits 2 with one line) without leaving a drive half-configured.

Every wait is a generous deadline that returns as soon as the thing happened (a loaded 2-core
machine); every process is stopped in a ``finally``, also when a check fails."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from rrps_description.geometry import load_robot, robot_path
from rrps_runtime.supervision import CONTROL_RT_PRIORITY, stop_children
from rrps_testing.canopen_rig import DriveSim, driver_process
from rrps_testing.driver_probe import DriverProbe
from rrps_testing.ros_harness import Spinner, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.exclusive]  # the drive simulator and driver at SCHED_RR
POLE = load_robot('pole_climber')
NAMESPACE = '/rrps_canopen'


def robot_yaml(tmp_path: Path, **drive_defaults) -> str:
    """The pole climber with its bus' ``drive_defaults`` changed, as a YAML file."""
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['bus']['drive_defaults'].update(drive_defaults)
    path = tmp_path / 'pole_climber_test.yaml'
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_six_drives_come_up_disabled_and_home_only_at_activation(tmp_path, ros_context, ros_domain_id):
    """Incremental encoders, homing on the retracted-end switch (method 17 on the legs that count
    up as they extend, 18 on those that count down): configure enables nothing and moves nothing;
    activation homes every leg to its switch, then holds it in CSP."""
    robot = robot_yaml(tmp_path, homing=17, homing_speed=0.05)
    data = yaml.safe_load(Path(robot).read_text())
    for leg in ('leg_2', 'leg_4', 'leg_6'):
        data['bus']['drives'][leg]['homing'] = 18
    Path(robot).write_text(yaml.safe_dump(data))
    processes = []
    with DriveSim(robot) as sim:
        try:
            processes.append(driver_process(sim.port, robot=robot, namespace=NAMESPACE, domain_id=ros_domain_id))
            probe = DriverProbe(context=ros_context, namespace=NAMESPACE)
            with Spinner(ros_context, [probe]):
                assert wait_for(lambda: probe.states and probe.latest()), processes[0].poll()
                drives = sim.status()['drives']
                assert {d['state'] for d in drives.values()} == {'switch_on_disabled'}, drives
                assert {d['nmt'] for d in drives.values()} == {'OPERATIONAL'}
                assert not any(d['homed'] for d in drives.values())
                np.testing.assert_allclose([d['position'] for d in drives.values()], POLE.home_lengths, atol=1e-12)
                assert not probe.latest()[3].active and probe.latest()[3].hardware == 'canopen'

                assert probe.activate()
                drives = sim.status()['drives']
                assert {d['state'] for d in drives.values()} == {'operation_enabled'}, drives
                assert all(d['homed'] and d['mode'] == 8 for d in drives.values()), drives
                np.testing.assert_allclose([d['position'] for d in drives.values()], 0.3, atol=1e-9)
                np.testing.assert_allclose([d['target'] for d in drives.values()], 0.3, atol=2e-6)
                assert wait_for(lambda: np.allclose(probe.states[-1][1].position[:6], 0.3, atol=2e-6))
                assert wait_for(lambda: probe.latest()[3].active)
                if os.geteuid() == 0:  # permitted: the bus' SYNC cycle and receive thread above the command path
                    assert sorted(realtime_priorities(processes[0].pid))[-2:] == \
                        [CONTROL_RT_PRIORITY + 1, CONTROL_RT_PRIORITY + 2]
        finally:
            codes = stop_children(processes)
    assert codes == [0], processes[0].stderr.read()[-3000:]


def realtime_priorities(pid: int) -> list[int]:
    """The real-time priorities of process ``pid``'s threads, read from the kernel (/proc)."""
    found = []
    for tid in os.listdir(f'/proc/{pid}/task'):
        with open(f'/proc/{pid}/task/{tid}/stat') as f:
            fields = f.read().rsplit(')', 1)[1].split()
        if int(fields[38]) in (os.SCHED_FIFO, os.SCHED_RR):  # policy, then rt_priority before it
            found.append(int(fields[37]))
    return found


@pytest.mark.parametrize('defaults, drives, behaviour, message', [
    ({'eds': 'cia401_io_module.eds'}, {}, None,
     r'leg_1 \(node 1\), .*leg_6 \(node 6\): its EDS .*cia401_io_module.eds lacks 0x6040 controlword'),
    ({}, {'leg_3': {'node_id': 13}}, None,
     r'leg_3 \(node 13\): no boot-up message, heartbeat or SDO answer within bus.boot_timeout 5 s: wrong node id'),
    ({'homing': 17, 'home_position': 0.3}, {}, None,
     r'bus.drives.leg_2.home_position: homing method 17 finds the negative limit switch, which for direction -1 '
     r'is the extended end of the stroke; 0.3 m is nearer the other end'),
    ({'homing': 37, 'home_position': 0.425}, {}, {'homing_methods': [35]},
     r'homing method 37 not supported by leg_1 \(node 1\), .*leg_6 \(node 6\); supported: 35 \(0x60E3'),
])
def test_a_wrong_eds_node_id_or_homing_is_refused_at_configure_and_no_drive_runs(tmp_path, ros_domain_id, defaults,
                                                                               drives, behaviour, message):
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['bus']['drive_defaults'].update(defaults)
    for leg, keys in drives.items():
        data['bus']['drives'][leg].update(keys)
    robot = tmp_path / 'misconfigured.yaml'
    robot.write_text(yaml.safe_dump(data))
    with DriveSim('pole_climber', behaviour=behaviour) as sim:
        driver = driver_process(sim.port, robot=str(robot), namespace=NAMESPACE, domain_id=ros_domain_id)
        try:
            code = driver.wait(timeout=120)
        finally:
            stop_children([driver])
        err = driver.stderr.read()
        status = sim.status()['drives']
    assert code == 2 and re.search(message, err) and 'Traceback' not in err, err
    assert {d['state'] for d in status.values()} == {'switch_on_disabled'}, status
    assert {d['nmt'] for d in status.values()} <= {'PRE-OPERATIONAL'}, status
    np.testing.assert_allclose([d['position'] for d in status.values()], POLE.home_lengths, atol=1e-12)
