"""Child processes never outlive their supervisor (rrps_runtime.supervision)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from rrps_runtime.supervision import (
    CONTROL_NICE,
    CONTROL_RT_PRIORITY,
    OBSERVER_NICE,
    Respawner,
    group_priority_of,
    priority_of,
    scheduling_of,
    start_child,
    stop_child,
    stop_children,
)

# A supervisor that starts a long-running child, prints the child's pid and waits.
SUPERVISOR = textwrap.dedent('''
    import sys, time
    from rrps_runtime.supervision import start_child
    child = start_child([sys.executable, '-c', 'import time\\nwhile True: time.sleep(0.05)'])
    print(child.pid, flush=True)
    time.sleep(600)
''')


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie is dead too (its parent, init, reaps it)
    try:
        with open(f'/proc/{pid}/stat') as f:
            return f.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except FileNotFoundError:
        return False


def _wait_dead(pid: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not _alive(pid):
            return True
        time.sleep(0.02)
    return not _alive(pid)


def test_a_killed_supervisor_takes_its_child_with_it():
    supervisor = subprocess.Popen([sys.executable, '-c', SUPERVISOR], stdout=subprocess.PIPE,
                                  text=True)
    try:
        child = int(supervisor.stdout.readline())
        assert _alive(child)
        supervisor.send_signal(signal.SIGKILL)  # no chance to clean up
        supervisor.wait()
        assert _wait_dead(child, 60.0), 'the child outlived its supervisor'
    finally:
        if supervisor.poll() is None:
            supervisor.kill()


def test_stop_child_terminates_then_kills():
    stubborn = start_child([sys.executable, '-c',
                            'import signal, time\nsignal.signal(signal.SIGTERM, signal.SIG_IGN)\n'
                            'print(1, flush=True)\nwhile True: time.sleep(0.05)'],
                           stdout=subprocess.PIPE)
    stubborn.stdout.readline()  # SIGTERM is ignored from here on
    assert stop_child(stubborn, timeout=0.5) == -signal.SIGKILL
    polite = start_child([sys.executable, '-c', 'import time\nwhile True: time.sleep(0.05)'])
    assert stop_child(polite, timeout=60.0) == -signal.SIGTERM  # returns as soon as it is gone


def test_a_child_starts_at_the_priority_asked_for_when_permitted():
    sleeper = [sys.executable, '-c', 'import time; time.sleep(30)']
    observer = start_child(sleeper, nice=OBSERVER_NICE)  # a higher nice value is always permitted
    control = start_child(sleeper, nice=CONTROL_NICE)
    try:
        assert priority_of(observer.pid) == OBSERVER_NICE
        # A lower one needs root or CAP_SYS_NICE (CI runs as root); without it: normal priority.
        expected = CONTROL_NICE if os.geteuid() == 0 else priority_of(os.getpid())
        assert priority_of(control.pid) == expected
    finally:
        stop_child(observer)
        stop_child(control)


def test_a_control_child_runs_real_time_in_a_scheduling_group_of_its_own():
    sleeper = [sys.executable, '-c', 'import time; time.sleep(30)']
    control = start_child(sleeper, nice=CONTROL_NICE, realtime=CONTROL_RT_PRIORITY)
    plain = start_child(sleeper)
    try:
        assert os.getsid(control.pid) == control.pid  # leads its own session: its own autogroup
        assert os.getsid(plain.pid) == os.getsid(0)  # a child without priorities stays in ours
        assert scheduling_of(plain.pid) == scheduling_of(os.getpid())
        if os.geteuid() == 0:  # CI runs as root; without CAP_SYS_NICE nothing is raised
            assert scheduling_of(control.pid) == f'SCHED_RR {CONTROL_RT_PRIORITY}'
            assert priority_of(control.pid) == CONTROL_NICE
            if group_priority_of(control.pid) is not None:  # a kernel with autogroup
                assert group_priority_of(control.pid) == CONTROL_NICE
                assert group_priority_of(plain.pid) == group_priority_of(os.getpid())
    finally:
        stop_children([control, plain])


#: A child that takes 0.5 s to stop after a SIGTERM and exits 3 if a second one comes meanwhile.
TERMINATED_ONCE = ('import signal, sys, time\n'
                   'got = []\n'
                   'signal.signal(signal.SIGTERM, lambda *_: got.append(1))\n'
                   'print("ready", flush=True)\n'
                   'while not got: time.sleep(0.01)\n'
                   'time.sleep(0.5)\n'
                   'sys.exit(3 if len(got) > 1 else 0)\n')


def test_a_respawner_terminated_early_and_stopped_later_sends_one_sigterm_and_restarts_nothing():
    robot = Respawner({'child': lambda first: start_child([sys.executable, '-c', TERMINATED_ONCE],
                                                          stdout=subprocess.PIPE, text=True)})
    child = robot.children['child']
    try:
        assert child.stdout.readline().strip() == 'ready'
        robot.terminate()   # as the demo does before tearing down its own nodes
        time.sleep(0.1)
        assert robot.stop(timeout=30.0) == [0]   # no second SIGTERM while it stops
        assert robot.poll() == [] and robot.children['child'] is child
    finally:
        stop_child(child)


@pytest.mark.skipif(os.geteuid() != 0, reason='lowering a nice value needs root (CAP_SYS_NICE)')
def test_a_niced_child_is_put_back_at_nice_0_before_its_sigterm():
    """An observer at nice 5 (and its autogroup) stops at nice 0: on a busy machine it closes its
    files within the stop timeout."""
    code = textwrap.dedent('''
        import os, signal, sys, time
        os.setpriority(os.PRIO_PROCESS, 0, 5)
        with open('/proc/self/autogroup', 'w') as f:
            f.write('5')
        def stop(*_):
            with open('/proc/self/autogroup') as f:
                group = f.read().split()[-1]
            print(os.getpriority(os.PRIO_PROCESS, 0), group, flush=True)
            sys.exit(0)
        signal.signal(signal.SIGTERM, stop)
        print('ready', flush=True)
        while True:
            time.sleep(0.05)
    ''')
    child = subprocess.Popen([sys.executable, '-c', code], stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert child.stdout.readline().strip() == 'ready'
        assert priority_of(child.pid) == 5
        assert stop_children([child], timeout=30.0) == [0]
        assert child.stdout.read().split() == ['0', '0']   # its nice value and its autogroup's
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
