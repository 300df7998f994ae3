"""A node process finishes its shutdown when a second signal comes meanwhile (Ctrl-C pressed again,
``ros2 launch``'s SIGTERM after its SIGINT): the nodes close what they hold, and the process exits 0
(rrps_runtime.process.run_nodes)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import pytest

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
