"""Nodes of the command path claim their own scheduling, as ros2_control's controller manager
does: started plain (no ``chrt``), a composed process gives its executor's thread, its timer
threads and the middleware's threads the SCHED_RR priority and CPUs of its nodes' parameters,
logs it and reports it on /diagnostics; where that is not permitted it says why and runs on.
What the threads got is read from /proc, not from the node."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray

from rrps_interfaces.kinematics import IkStatus
from rrps_interfaces.status import SchedulingStatus, source_node
from rrps_runtime.supervision import stop_child
from rrps_testing.ci import require
from rrps_testing.processes import free_port
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.skipif(not sys.platform.startswith('linux'), reason='Linux scheduling')

NS = f'/sched_{os.getpid()}'


def _threads(pid: int) -> dict[str, list[tuple[int, int, set[int]]]]:
    """{thread name: [(policy, rt priority, allowed CPUs), ...]} of a process, from /proc."""
    out: dict[str, list] = {}
    for tid in os.listdir(f'/proc/{pid}/task'):
        base = f'/proc/{pid}/task/{tid}'
        try:
            with open(f'{base}/comm') as f:
                name = f.read().strip()
            with open(f'{base}/stat') as f:
                fields = f.read().rsplit(')', 1)[1].split()
            with open(f'{base}/status') as f:
                cpus = next(line.split(':', 1)[1].strip() for line in f if line.startswith('Cpus_allowed_list'))
        except OSError:
            continue
        allowed = set()
        for part in cpus.split(','):
            lo, _, hi = part.partition('-')
            allowed.update(range(int(lo), int(hi or lo) + 1))
        out.setdefault(name, []).append((int(fields[38]), int(fields[37]), allowed))
    return out


def _start(ros_domain_id: int, *params: str, prefix: tuple[str, ...] = ()) -> subprocess.Popen:
    args = [*prefix, sys.executable, '-m', 'rrps_bringup.compose', 'ik_node', 'fk_node', '--ros-args',
            '-r', f'__ns:={NS}']
    for p in params:
        args += ['-p', p]
    return subprocess.Popen(args, env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _statuses(ros_context, child):
    """The ik_node and fk_node statuses (their key-values) once both were heard saying what
    scheduling they got (a status sent before the spinning thread claimed it has none)."""
    probe = Probe(context=ros_context, namespace=NS)
    arrays = probe.collect(DiagnosticArray, '/diagnostics')
    with Spinner(ros_context, [probe]):
        def heard():
            names = {source_node(s.name): s for a in list(arrays) for s in a.status
                     if any(kv.key == 'scheduling_policy' for kv in s.values)}
            return names if {'ik_node', 'fk_node'} <= set(names) else None
        assert wait_for(heard, timeout=60.0), child.poll()
        return {name: s.values for name, s in heard().items() if name in ('ik_node', 'fk_node')}


def test_a_plain_launch_claims_the_scheduling_of_its_nodes(ros_context, ros_domain_id):
    cpu = min(os.sched_getaffinity(0))
    child = _start(ros_domain_id, 'rt_priority:=7', f'cpu_affinity:=[{cpu}]')
    try:
        statuses = _statuses(ros_context, child)
        threads = _threads(child.pid)
    finally:
        stop_child(child)
    log = child.stdout.read()
    permitted = os.geteuid() == 0
    for name, values in statuses.items():
        got = SchedulingStatus.from_key_values(values)
        assert got.scheduling_cpus == (cpu,)
        assert (got.scheduling_policy, got.scheduling_priority) == (('SCHED_RR', 7) if permitted else
                                                                    ('SCHED_OTHER', 0)), got
        assert f'[{NS[1:]}.{name}]: command path scheduling: ' in log
    IkStatus.from_key_values(statuses['ik_node'])  # the node's own status contract holds beside it
    executor = threads['rrps-executor']
    middleware = [t for name, ts in threads.items() if name.startswith('dds.') for t in ts]
    assert middleware, sorted(threads)
    if permitted:  # the executor, its timer threads and the middleware's: SCHED_RR 7 on the CPU
        assert all(t == (2, 7, {cpu}) for t in executor + middleware), (executor, middleware)
        assert len(executor) >= 2  # the spinning thread and at least one timer thread
        others = [t for name, ts in threads.items() if name == 'python' for t in ts]
        assert all(policy == 0 for policy, _, _ in others)  # the rest keeps the normal policy


@pytest.mark.skipif(os.geteuid() != 0 or not shutil.which('setpriv') or not shutil.which('prlimit'),
                    reason="needs root and util-linux' setpriv and prlimit to take the permission away")
def test_without_the_permission_the_nodes_say_why_and_run_on(ros_context, ros_domain_id):
    drop = ('setpriv', '--bounding-set', '-sys_nice', '--inh-caps', '-sys_nice', 'prlimit', '--rtprio=0')
    child = _start(ros_domain_id, 'rt_priority:=12', prefix=drop)
    try:
        statuses = _statuses(ros_context, child)
        threads = _threads(child.pid)
        time.sleep(0.5)
        assert child.poll() is None
    finally:
        stop_child(child)
    for values in statuses.values():
        got = SchedulingStatus.from_key_values(values)
        assert got.scheduling_policy == 'SCHED_OTHER' and 'SCHED_RR 12' in got.scheduling_refused
    assert all(policy == 0 for ts in threads.values() for policy, _, _ in ts)


def test_the_viewer_claims_its_operator_input_thread_and_leaves_drawing_normal(ros_domain_id):
    """The deadman's presses and the link's round trip reach viewer_node on viser's websocket
    thread, outside the executor: it gets the command path's priority; drawing does not."""
    require(os.geteuid() == 0, 'SCHED_RR needs root (CI runs as root)')
    port = free_port()
    child = subprocess.Popen([sys.executable, '-m', 'rrps_bringup.compose', 'viewer_node', '--ros-args',
                              '-r', f'__ns:={NS}', '-p', 'rt_priority:=6', '-p', f'port:={port}',
                              '-p', 'render_rate:=5.0'],
                             env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        def claimed():
            threads = _threads(child.pid)
            return threads if any(t[:2] == (2, 6) for t in threads.get('rrps-executor', [])) else None
        assert wait_for(claimed, timeout=90.0), child.poll()
        threads = claimed()
    finally:
        stop_child(child)
    assert [t[:2] for t in threads['rrps-in-viser']] == [(2, 6)], threads.get('rrps-in-viser')
    claimed_names = ('rrps-executor', 'rrps-in-', 'dds.')
    others = [t for name, ts in threads.items() if not name.startswith(claimed_names) for t in ts]
    assert others and all(policy == 0 for policy, _, _ in others)  # drawing among them
