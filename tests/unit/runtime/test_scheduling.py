"""The scheduling a thread claims (rrps_runtime.scheduling), read back from /proc, not from the code."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from rrps_runtime.scheduling import MAX_RT_PRIORITY, Request, background, claim, claim_thread

pytestmark = pytest.mark.skipif(not sys.platform.startswith('linux'), reason='Linux scheduling')

# /proc/<pid>/task/<tid>/stat fields after the command (field 3 is index 0): rt_priority is
# field 40, policy field 41 (proc(5)); SCHED_RR is 2 and SCHED_RESET_ON_FORK is not shown there.
_RT_PRIORITY, _POLICY = 40 - 3, 41 - 3


def _proc_scheduling(tid: int, pid: int | None = None) -> tuple[int, int, set[int]]:
    """(policy, rt priority, allowed CPUs) of a thread as the kernel shows it in /proc."""
    base = f'/proc/{pid or os.getpid()}/task/{tid}'
    with open(f'{base}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    with open(f'{base}/status') as f:
        cpus = next(line.split(':', 1)[1].strip() for line in f if line.startswith('Cpus_allowed_list'))
    allowed = set()
    for part in cpus.split(','):
        lo, _, hi = part.partition('-')
        allowed.update(range(int(lo), int(hi or lo) + 1))
    return int(fields[_POLICY]), int(fields[_RT_PRIORITY]), allowed


def _permitted() -> bool:
    """Whether this process may use a real-time policy (root, CAP_SYS_NICE, RLIMIT_RTPRIO)."""
    import resource
    return os.geteuid() == 0 or resource.getrlimit(resource.RLIMIT_RTPRIO)[0] >= 3


def _in_thread(fn):
    """fn() in a thread of its own (so the test's thread keeps its scheduling); its result and tid."""
    out = {}

    def run():
        out['tid'] = threading.get_native_id()
        out['result'] = fn()
    t = threading.Thread(target=run)
    t.start()
    t.join(10.0)
    return out['result'], out['tid']


def test_a_claimed_thread_has_what_the_kernel_shows():
    cpu = min(os.sched_getaffinity(0))

    def work():
        granted = claim_thread(Request(3, (cpu,)), 'rrps-test')
        return granted, _proc_scheduling(threading.get_native_id())
    (granted, (policy, priority, cpus)), tid = _in_thread(work)
    assert cpus == {cpu} and granted.cpus == (cpu,)
    if _permitted():
        assert (policy, priority) == (2, 3)
        assert granted.realtime and granted.priority == 3 and granted.refused == ''
        assert 'SCHED_RR 3 on CPU' in granted.text()
    else:
        assert policy == 0 and not granted.realtime and 'SCHED_RR 3' in granted.refused


def test_threads_and_processes_started_by_a_realtime_thread_start_at_the_normal_policy():
    """SCHED_RESET_ON_FORK: only the claimed thread runs at real time, not what it starts."""
    def work():
        claim_thread(Request(2))
        inner = {}
        t = threading.Thread(target=lambda: inner.update(policy=_proc_scheduling(threading.get_native_id())[0]))
        t.start()
        t.join(10.0)
        child = subprocess.run([sys.executable, '-c', 'import os; print(os.sched_getscheduler(0))'],
                               capture_output=True, text=True, timeout=60)
        return inner['policy'], int(child.stdout)
    (thread_policy, process_policy), _ = _in_thread(work)
    assert thread_policy == os.SCHED_OTHER and process_policy == os.SCHED_OTHER


def test_a_thread_goes_back_to_the_normal_policy_in_the_background():
    def work():
        claim_thread(Request(2))
        claimed = _proc_scheduling(threading.get_native_id())[0]
        background('rrps-worker')
        return claimed, _proc_scheduling(threading.get_native_id())[0]
    (claimed, after), _ = _in_thread(work)
    assert claimed == (2 if _permitted() else 0) and after == 0


@pytest.mark.skipif(os.geteuid() != 0 or not shutil.which('setpriv'),
                    reason="needs root and util-linux' setpriv to start a process without the permission")
def test_without_the_permission_a_claim_says_why_and_the_thread_runs_on():
    script = textwrap.dedent('''
        import json, os
        from rrps_runtime.scheduling import Request, claim
        g = claim(Request(10))
        print(json.dumps({'policy': g.policy, 'refused': g.refused, 'kernel': os.sched_getscheduler(0)}))
    ''')
    # root without CAP_SYS_NICE (and RLIMIT_RTPRIO 0): no real time, no lower nice value
    drop = ['setpriv', '--bounding-set', '-sys_nice', '--inh-caps', '-sys_nice']
    out = subprocess.run([*drop, 'prlimit', '--rtprio=0', sys.executable, '-c', script], capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert got['policy'] == 'SCHED_OTHER' and got['kernel'] == os.SCHED_OTHER
    assert 'SCHED_RR 10' in got['refused'] and 'nice -10' in got['refused']  # neither was permitted


def test_requests_merge_and_shift_within_their_bounds():
    assert Request(5, (0,)).merged(Request(10, (1,))) == Request(10, (0, 1))
    assert Request(5).merged(Request(0, (1,))) == Request(5, (1,))
    assert Request(10).shifted(2) == Request(12)
    assert Request(0).shifted(2) == Request(0)
    assert Request(MAX_RT_PRIORITY).shifted(2).priority == MAX_RT_PRIORITY
    with pytest.raises(ValueError, match='rt_priority'):
        Request(MAX_RT_PRIORITY + 1)
    with pytest.raises(ValueError, match='cpu_affinity'):
        Request(1, (-1,))


def test_a_claim_on_threads_that_ended_counts_only_the_living():
    t = threading.Thread(target=lambda: None)
    t.start()
    t.join()
    while str(t.native_id) in os.listdir('/proc/self/task'):  # the OS thread ends after join()
        time.sleep(0.01)
    granted = claim(Request(0), [t.native_id])
    assert granted.threads == 0
