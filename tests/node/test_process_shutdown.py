"""A node process finishes its shutdown when a second signal comes meanwhile (Ctrl-C pressed again,
``ros2 launch``'s SIGTERM after its SIGINT): the nodes close what they hold, and the process exits 0
(rrps_runtime.process.run_nodes). A node process whose start-up blocks still ends when its
supervisor dies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from rrps_runtime.process import SHUTDOWN_DEADLINE
from rrps_runtime.supervision import stop_child

pytestmark = pytest.mark.ros

#: A process of one node whose teardown takes 1 s (as a recorder closing its bag does) and says
#: when it starts and when it is done.
SLOW_TEARDOWN = textwrap.dedent('''
    import sys, time
    from rclpy.node import Node
    from rrps_runtime.process import run_nodes

    class SlowTeardown(Node):
        def __init__(self, **kwargs):
            super().__init__('slow_teardown', **kwargs)
            print('ready', flush=True)

        def destroy_node(self):
            print('tearing down', flush=True)
            time.sleep(1.0)
            print('torn down', flush=True)
            super().destroy_node()

    run_nodes([SlowTeardown])
''')


@pytest.mark.parametrize('first, second', [(signal.SIGINT, signal.SIGINT), (signal.SIGTERM, signal.SIGTERM),
                                           (signal.SIGINT, signal.SIGTERM)])
def test_a_second_signal_during_the_shutdown_does_not_cut_it_short(ros_domain_id, first, second):
    process = subprocess.Popen([sys.executable, '-c', SLOW_TEARDOWN], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)))
    try:
        assert process.stdout.readline().strip() == 'ready'
        process.send_signal(first)
        assert process.stdout.readline().strip() == 'tearing down'
        process.send_signal(second)   # during the teardown's 1 s
        out, err = process.communicate(timeout=60)
    finally:
        stop_child(process)
    assert process.returncode == 0, err[-2000:]
    assert out.strip() == 'torn down', out
    assert f'{second.name} while shutting down: finishing the shutdown' in err, err
    assert 'Traceback' not in err, err


#: A supervisor (start_child: the parent-death signal and watcher) of a node process whose node's
#: start-up never returns; it says the child's pid, then waits to be killed.
SUPERVISOR = textwrap.dedent('''
    import sys, textwrap, time
    from rrps_runtime.supervision import start_child

    BLOCKED = textwrap.dedent(\'\'\'
        import threading
        from rclpy.node import Node
        from rrps_runtime.process import run_nodes

        class Blocked(Node):
            def __init__(self, **kwargs):
                super().__init__('blocked', **kwargs)
                print('constructing', flush=True)
                threading.Event().wait()

        run_nodes([Blocked])
    \'\'\')
    child = start_child([sys.executable, '-c', BLOCKED])
    print(child.pid, flush=True)
    time.sleep(600)
''')


def _running(pid: int) -> bool:
    try:
        with open(f'/proc/{pid}/stat') as f:
            return f.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except OSError:
        return False


def test_a_node_process_blocked_in_its_start_up_ends_with_its_supervisor(ros_domain_id, tmp_path):
    """The supervisor is killed while its child's node is still being built (blocked): the child
    ends within the shutdown deadline, saying where each thread was."""
    err = tmp_path / 'stderr'
    with open(err, 'w') as stderr:
        supervisor = subprocess.Popen([sys.executable, '-c', SUPERVISOR], stdout=subprocess.PIPE, stderr=stderr,
                                      text=True, env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)))
    try:
        child = int(supervisor.stdout.readline())
        assert supervisor.stdout.readline().strip() == 'constructing'
        supervisor.kill()
        supervisor.wait()
        t0 = time.monotonic()
        while _running(child) and time.monotonic() - t0 < SHUTDOWN_DEADLINE + 20.0:   # a loaded machine
            time.sleep(0.1)
        alive = _running(child)
    finally:
        stop_child(supervisor)
        if _running(child):
            os.kill(child, signal.SIGKILL)
    assert not alive, 'the node process outlived its supervisor'
    assert 'most recent call first' in err.read_text(), err.read_text()[-2000:]   # faulthandler's dump
