"""The three installed executables as separate processes over DDS on localhost: the chain
target_pose -> ik_node -> driver_node -> fk_node -> pose returns the target, and Ctrl-C (SIGINT)
ends every process cleanly (exit code 0, no traceback).

Process start-up and shutdown take seconds on an idle machine and many more on a loaded one:
every wait here is a generous deadline that returns as soon as the process is there or gone."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_testing.ci import require
from rrps_testing.node_helpers import pose_error, target
from rrps_testing.ros_harness import DEADLINE, Probe, Spinner, wait_for

BIN = Path(sys.executable).parent
POLE = load_robot('pole_climber')
NAMESPACE = '/rrps_test'


def start(executable, domain_id, *params):
    path = BIN / executable
    require(path.exists(), f'{path} is not installed (pip install -e src/...)')
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               PYTHONUNBUFFERED='1')
    args = [str(path), '--ros-args', '-r', f'__ns:={NAMESPACE}', '-p', 'robot:=pole_climber']
    for p in params:
        args += ['-p', p]
    return subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def stop(process, timeout=DEADLINE):
    """SIGINT, then kill after ``timeout``; (exit code, None if it had to be killed; stderr)."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    try:
        _, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        _, err = process.communicate()
        return None, err
    return process.returncode, err


@pytest.mark.ros
@pytest.mark.slow
def test_installed_executables_close_the_chain_and_stop_on_ctrl_c(ros_context, ros_domain_id):
    processes = {}
    try:
        processes['driver_node'] = start('driver_node', ros_domain_id, 'auto_activate:=true', 'time_constant:=0.0',
                                         'limit_speed:=false', 'publish_on_command:=true')
        processes['ik_node'] = start('ik_node', ros_domain_id)
        processes['fk_node'] = start('fk_node', ros_domain_id)
        probe = Probe(context=ros_context, namespace=NAMESPACE)
        poses = probe.collect(PoseStamped, 'pose')
        pub = probe.publisher(PoseStamped, 'target_pose', command=True)
        goals = [(POLE.home_position + [0.01, -0.005, 0.02],
                  rotation_vector_to_quat_xyzw(np.array([0.05, 0.0, -0.08]))),
                 (POLE.home_position + [-0.02, 0.01, -0.01],
                  rotation_vector_to_quat_xyzw(np.array([0.0, -0.06, 0.1])))]
        with Spinner(ros_context, [probe]):
            assert wait_for(lambda: poses and pub.get_subscription_count() == 1), \
                {name: p.poll() for name, p in processes.items()}
            for p, q in goals:
                def arrived():
                    pub.publish(target(probe, p, q))
                    return max(pose_error(poses[-1], p, q)) < 1e-6
                assert wait_for(arrived, period=0.01), pose_error(poses[-1], p, q)
        assert all(p.poll() is None for p in processes.values())
    finally:
        results = {name: stop(p) for name, p in processes.items()}
    for name, (code, err) in results.items():
        assert code == 0, f'{name} exited with {code}: {err[-2000:]}'
        assert 'Traceback' not in err, err


@pytest.mark.ros
@pytest.mark.parametrize('executable, param, message', [
    ('ik_node', 'robot:=no_such_robot', 'no_such_robot'),
    ('driver_node', 'mode:=fast', 'mode must be one of'),
    ('driver_node', 'hardware:=cia402', "unknown hardware 'cia402'; known: canopen, simulated"),
])
def test_invalid_parameters_exit_2_with_one_line(ros_domain_id, executable, param, message):
    process = start(executable, ros_domain_id, param)
    code, err = stop(process) if process.wait(timeout=DEADLINE) is not None else (None, '')
    assert code == 2 and message in err and 'Traceback' not in err, err
