"""rrps_testing.machine_turns: shared turns overlap, an exclusive turn runs alone and is not starved by
shared takers arriving while it waits, and a killed holder's turn is free again."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

from rrps_testing.machine_turns import MachineTurns

WAIT = 10.0


def _holder(turns: MachineTurns, exclusive: bool, inside: threading.Event, leave: threading.Event,
            log: list, name: str) -> threading.Thread:
    def run() -> None:
        with turns.take(exclusive=exclusive):
            log.append(('in', name))
            inside.set()
            leave.wait(WAIT)
            log.append(('out', name))
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_shared_turns_overlap(tmp_path):
    turns, log = MachineTurns(str(tmp_path)), []
    leave = threading.Event()
    a_in, b_in = threading.Event(), threading.Event()
    threads = [_holder(turns, False, a_in, leave, log, 'a'), _holder(turns, False, b_in, leave, log, 'b')]
    assert a_in.wait(WAIT) and b_in.wait(WAIT)          # both inside at once
    leave.set()
    for t in threads:
        t.join(WAIT)
    assert sorted(log) == [('in', 'a'), ('in', 'b'), ('out', 'a'), ('out', 'b')]


def test_an_exclusive_turn_waits_for_the_shared_holders_and_later_shared_takers_wait_for_it(tmp_path):
    turns, log = MachineTurns(str(tmp_path)), []
    leave_shared, leave_exclusive, leave_late = threading.Event(), threading.Event(), threading.Event()
    shared_in, exclusive_in, late_in = threading.Event(), threading.Event(), threading.Event()
    threads = [_holder(turns, False, shared_in, leave_shared, log, 'shared')]
    assert shared_in.wait(WAIT)
    threads.append(_holder(turns, True, exclusive_in, leave_exclusive, log, 'exclusive'))
    time.sleep(0.3)
    assert not exclusive_in.is_set()                      # a shared holder is inside
    threads.append(_holder(turns, False, late_in, leave_late, log, 'late'))
    time.sleep(0.3)
    assert not late_in.is_set()                           # queued behind the waiting exclusive taker
    leave_shared.set()
    assert exclusive_in.wait(WAIT)
    time.sleep(0.3)
    assert not late_in.is_set()                           # the exclusive holder is alone
    leave_exclusive.set()
    assert late_in.wait(WAIT)
    leave_late.set()
    for t in threads:
        t.join(WAIT)
    assert log == [('in', 'shared'), ('out', 'shared'), ('in', 'exclusive'), ('out', 'exclusive'),
                   ('in', 'late'), ('out', 'late')]


def test_a_killed_holders_turn_is_free_again(tmp_path):
    code = ('import sys, time; from rrps_testing.machine_turns import MachineTurns\n'
            'with MachineTurns(sys.argv[1]).take(exclusive=True):\n'
            '    print("in", flush=True); time.sleep(60)\n')
    child = subprocess.Popen([sys.executable, '-c', code, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == 'in'
        turns, log, leave, inside = MachineTurns(str(tmp_path)), [], threading.Event(), threading.Event()
        thread = _holder(turns, False, inside, leave, log, 'after')
        time.sleep(0.3)
        assert not inside.is_set()
        child.kill()
        assert inside.wait(WAIT)
        leave.set()
        thread.join(WAIT)
    finally:
        child.kill()
        child.wait()
        child.stdout.close()
