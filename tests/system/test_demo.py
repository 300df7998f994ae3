"""rrps-demo as users run it: the headless smoke test, the URL and token banner, Ctrl-C, bad input."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from rrps_runtime.supervision import (
    CONTROL_NICE,
    CONTROL_RT_PRIORITY,
    OBSERVER_NICE,
    OPERATOR_NICE,
    OPERATOR_RT_PRIORITY,
    child_pids,
    priority_of,
    process_alive,
    scheduling_of,
)
from rrps_testing.processes import demo_excerpt, free_port, interrupt, wait_until

pytestmark = [pytest.mark.ros]

DEMO = Path(sys.executable).parent / 'rrps-demo'


def _env(domain_id: int) -> dict:
    return {**os.environ, 'ROS_DOMAIN_ID': str(domain_id),
            'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'PYTHONUNBUFFERED': '1'}


@pytest.fixture(autouse=True)
def _in_tmp_path(tmp_path, monkeypatch):
    """The demo writes its flight recordings to ./rrps_recordings and its run directory (the
    hardware's state file) to the temporary directory: both in the test's own (a killed demo cannot
    remove its run directory)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv('TMPDIR', str(tmp_path))


def _command() -> list[str]:
    return [str(DEMO)] if DEMO.exists() else [sys.executable, '-m', 'rrps_bringup.demo']


@pytest.mark.slow
def test_headless_demo_runs_a_teleop_session_and_a_climb(ros_domain_id):
    """On the simulated hardware. The same session on simulated CANopen drives (rrps-drive-sim, a
    loopback bus) runs in a world: test_demo_scenarios.py, pole_leaning on canopen."""
    proc = subprocess.Popen([*_command(), '--headless', '--port', str(free_port()), '--hardware', 'simulated'],
                            env=_env(ros_domain_id), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = proc.communicate(timeout=480)
    finally:
        interrupt(proc)
    assert proc.returncode == 0, demo_excerpt(out)
    for line in ('[PASS] deadman held: teleop engaged', '[PASS] slave followed the master',
                 '[PASS] deadman released: disengaged', '[PASS] climb step executed and ended idle',
                 '[PASS] both rings climbed', '[PASS] viewer drew'):
        assert line in out, demo_excerpt(out)
    assert '[FAIL]' not in out
    assert 'when stopped' not in out and 'leaked' not in out, demo_excerpt(out)   # every child stopped cleanly


def test_demo_prints_url_and_token_serves_the_viewer_and_stops_on_ctrl_c(ros_domain_id):
    port = free_port()
    proc = subprocess.Popen([*_command(), '--port', str(port), '--token', 'token-for-test'],
                            env=_env(ros_domain_id), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        lines = []
        deadline = time.monotonic() + 120  # start-up of the processes on a loaded machine
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            lines.append(line)
            if 'operator token:' in line and 'token-for-test' in line and 'viewer:' in ''.join(lines):
                break
        text = ''.join(lines)
        assert f'http://127.0.0.1:{port}' in text, text
        assert 'operator token: token-for-test' in text, text
        with urllib.request.urlopen(f'http://127.0.0.1:{port}', timeout=60) as page:
            assert page.status == 200 and b'<html' in page.read().lower()
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)  # returns as soon as it stopped
    finally:
        interrupt(proc)
    assert proc.returncode == 0, out[-2000:]
    assert 'rrps demo: stopping' in out
    assert 'Traceback' not in out, out[-2000:]


@pytest.mark.parametrize('args, message', [
    (['--token', 'short'], '--token must have at least 8 characters'),
    (['--port', '70000'], '--port must be 1..65535'),
    (['--robot', 'no_such_robot'], "unknown robot 'no_such_robot'"),
])
def test_demo_rejects_bad_arguments_with_one_line(ros_domain_id, args, message):
    proc = subprocess.run([*_command(), *args], env=_env(ros_domain_id), capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert 'Traceback' not in proc.stderr


def test_compose_names_its_nodes_and_refuses_unknown_ones():
    from rrps_bringup.compose import main
    from rrps_bringup.registry import node_class, registered_nodes
    assert main(['no_such_node', '--ros-args']) == 2
    assert main(['ik_node', 'ik_node']) == 2
    assert main([]) == 2
    nodes = registered_nodes()
    assert set(nodes) == {'ik_node', 'fk_node', 'driver_node', 'master_node', 'teleop_node', 'climb_node',
                          'viewer_node', 'recorder_node', 'replay_node', 'markers_node', 'foxglove_node',
                          'robot_description_node', 'link_relay_node'}
    for name, node in nodes.items():
        assert node_class(name).__name__.endswith('Node')
        assert node.module.startswith(node.package + '.nodes.'), node  # each node in its package




def _described(pid: int) -> str:
    """A process' command line and what the kernel says it is doing (state, wait channel)."""
    try:
        with open(f'/proc/{pid}/cmdline', 'rb') as f:
            cmd = f.read().replace(b'\0', b' ').decode(errors='replace')[:120]
        with open(f'/proc/{pid}/status') as f:
            state = next((line.split(':', 1)[1].strip() for line in f if line.startswith('State:')), '?')
        with open(f'/proc/{pid}/wchan') as f:
            wchan = f.read().strip()
    except OSError as exc:
        return f'gone while described ({exc.strerror})'
    return f'{cmd} [{state}, waiting in {wchan or "-"}]'


@pytest.mark.slow
def test_a_killed_demo_takes_its_robot_processes_with_it_and_ctrl_c_stops_it_fast(ros_domain_id):
    for how in ('kill', 'ctrl-c'):
        proc = subprocess.Popen([*_command(), '--port', str(free_port())], env=_env(ros_domain_id),
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline:
                line = proc.stdout.readline()
                if not line or 'is live' in line:  # the banner: the robot processes are up
                    break
            children = child_pids(proc.pid)
            # the driver, the robot's IK and FK, its climbing node, master and teleop, the observers
            assert len(children) == 5, children
            if os.geteuid() == 0:  # the command path first in line for a core (CI is root)
                assert sorted(priority_of(c) for c in children) == sorted([CONTROL_NICE, CONTROL_NICE, CONTROL_NICE,
                                                                           OPERATOR_NICE, OBSERVER_NICE])
                # each node process claims its command path's priority itself once its nodes are up
                rt, operator = f'SCHED_RR {CONTROL_RT_PRIORITY}', f'SCHED_RR {OPERATOR_RT_PRIORITY}'
                wanted = sorted([rt, rt, rt, operator, f'nice {OBSERVER_NICE}'])
                assert wait_until(lambda: sorted(scheduling_of(c) for c in children) == wanted, 60), \
                    [scheduling_of(c) for c in children]
                assert scheduling_of(proc.pid) == operator  # the viewer's executor (the deadman)
            if how == 'kill':
                proc.kill()  # no chance to clean up: the parent-death signal stops them
                proc.wait()
            else:
                t0 = time.monotonic()
                proc.send_signal(signal.SIGINT)
                proc.wait(timeout=30)
                assert proc.returncode == 0
                # the demo itself is done within 2 s here (the CI machine is loaded: generous)
                assert time.monotonic() - t0 < 10.0
            deadline = time.monotonic() + 15
            while time.monotonic() < deadline and any(process_alive(c) for c in children):
                time.sleep(0.05)
            left = {c: _described(c) for c in children if process_alive(c)}
            assert not left, f'{how}: children outlived the demo: {left}'
        finally:
            interrupt(proc)


@pytest.mark.parametrize('state_file', ['', '/tmp/rrps-driver-state.json'])
def test_the_driver_command_line_parses_with_and_without_a_state_file(ros_domain_id, state_file):
    """rcl refuses an empty '-p name:=' (the recorder benchmark's driver did not start)."""
    import rclpy

    from rrps_bringup.demo_processes import driver_command
    argv = driver_command(robot='pole_climber', state_file=state_file, activate=True)
    context = rclpy.Context()
    rclpy.init(args=argv[2:], context=context)  # what the driver process's rclpy.init parses
    try:
        assert context.ok()
    finally:
        rclpy.shutdown(context=context)
    assert ('-p' in argv and f'state_file:={state_file}' in argv) == bool(state_file)
