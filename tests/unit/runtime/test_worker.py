"""Heavy work in a process of its own (rrps_runtime.worker): it runs elsewhere, and the caller's
threads keep running while it holds its own interpreter."""

from __future__ import annotations

import os
import threading
import time
from functools import partial

import pytest

from rrps_runtime.worker import WORKER_NICE, WorkerProcess

# sum() over a range is one C call: it holds the interpreter lock from start to end (no switch
# between bytecodes), as a compiled kernel that does not release it does.
GIL_HOLDING_TERMS = 60_000_000


def _hold_the_gil(terms: int) -> tuple[int, float, int]:
    """(the worker's pid, how long the GIL was held [s], its sum)."""
    t0 = time.perf_counter()
    total = sum(range(terms))
    return os.getpid(), time.perf_counter() - t0, total


def _scheduling() -> tuple[int, int]:
    return os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0)


def _fail() -> None:
    raise ValueError('the job failed')


class Ticker:
    """A thread that wakes every 5 ms and keeps its largest gap between wake-ups."""

    def __init__(self):
        self.largest = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        last = time.perf_counter()
        while not self._stop.wait(0.005):
            now = time.perf_counter()
            self.largest = max(self.largest, now - last)
            last = now

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join(5.0)


@pytest.fixture
def worker():
    w = WorkerProcess('rrps_test')
    yield w
    w.shutdown()


def test_a_job_runs_in_another_process_at_the_normal_policy(worker):
    assert worker.pid != os.getpid()
    policy, nice = worker.submit(_scheduling).result(60)
    assert policy == os.SCHED_OTHER and nice >= WORKER_NICE
    with pytest.raises(ValueError, match='the job failed'):
        worker.submit(_fail).result(60)


def test_the_callers_threads_run_while_a_job_holds_its_interpreter(worker):
    """The same GIL-holding job in a thread of this process stops a 5 ms ticker for its whole
    length (the baseline, same run); in the worker process it does not."""
    worker.submit(_hold_the_gil, 1000).result(60)  # the child is up
    with Ticker() as in_thread:
        box = {}
        job = threading.Thread(target=lambda: box.update(r=_hold_the_gil(GIL_HOLDING_TERMS)))
        job.start()
        job.join(120)
    held_here = box['r'][1]
    assert in_thread.largest > 0.5 * held_here  # the baseline: the ticker stopped meanwhile
    with Ticker() as beside_worker:
        pid, held_there, total = worker.submit(_hold_the_gil, GIL_HOLDING_TERMS).result(120)
    assert pid == worker.pid and total == GIL_HOLDING_TERMS * (GIL_HOLDING_TERMS - 1) // 2
    assert beside_worker.largest < 0.5 * held_there, (beside_worker.largest, held_there)


def _sleep(seconds: float) -> None:
    time.sleep(seconds)


def test_the_start_is_reported_once_the_warm_up_ran():
    """``when_started`` reports after the warm-up (a 0.5 s sleep), with its duration; a callback
    added after the start is called at once."""
    started = []
    w = WorkerProcess('rrps_test', warm_up=partial(_sleep, 0.5))
    try:
        w.when_started(started.append)
        assert w.submit(os.getpid).result(60) == w.pid
        deadline = time.monotonic() + 10
        while not started and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(started) == 1 and started[0] >= 0.5
        later = []
        w.when_started(later.append)
        assert len(later) == 1 and later[0] >= started[0]
    finally:
        w.shutdown()
