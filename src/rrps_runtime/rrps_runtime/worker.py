"""Heavy work in a process of its own, so that it never holds the interpreter (GIL) of a control node.

:class:`WorkerProcess` is a one-process ``concurrent.futures`` executor: ``submit(fn, *args)`` returns a Future. The
child runs at the normal policy (nice :data:`WORKER_NICE`), dies with its parent and is started, ``warm_up`` run,
when the pool is made. ``fn`` and its arguments travel pickled: module-level functions and plain data only.
Why: docs/deployment.md, "Process layout and priorities". Pure Python, no ROS import.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import threading
import time
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any, Callable

from rrps_runtime.scheduling import background, demote
from rrps_runtime.supervision import die_with_parent

__all__ = ['WorkerProcess', 'WORKER_NICE']

#: Nice value of a worker process: after the nodes, before observers.
WORKER_NICE = 2


def _start(name: str, parent: int, nice: int, warm_up: Callable[[], Any] | None) -> None:
    """In the child: die with the parent, run at the normal policy, warm up."""
    die_with_parent(parent)
    background(name)
    os.setpriority(os.PRIO_PROCESS, 0, max(os.getpriority(os.PRIO_PROCESS, 0), nice))
    if warm_up is not None:
        try:
            warm_up()
        except Exception as exc:  # noqa: BLE001 - the jobs still run, only slower at first
            print(f'{name}: warm-up failed: {type(exc).__name__}: {exc}', file=sys.stderr)


def _pid() -> int:
    return os.getpid()


class WorkerProcess:
    """One child process that runs submitted jobs one after the other (module docstring)."""

    def __init__(self, name: str, *, warm_up: Callable[[], Any] | None = None, nice: int = WORKER_NICE):
        before = {t.ident for t in threading.enumerate()}
        self.name = name
        self._created = time.monotonic()
        self._pool = ProcessPoolExecutor(
            max_workers=1, mp_context=multiprocessing.get_context('spawn'), initializer=_start,
            initargs=(name, os.getpid(), nice, warm_up))
        self._started = self._pool.submit(_pid)  # starts the child now, off any job's time
        # the pool's own threads (its queue feeder, its manager) only pass jobs along
        demote([t.native_id for t in threading.enumerate() if t.ident not in before and t.native_id])

    @property
    def pid(self) -> int:
        """The child's pid (waits for it to start)."""
        return self._started.result()

    def when_started(self, callback: Callable[[float], Any]) -> None:
        """Call ``callback(seconds)`` once the child started and warmed up (at once if it has),
        with the seconds that took; not called when it failed to start."""
        def started(future: Future) -> None:
            if not future.cancelled() and future.exception() is None:
                callback(time.monotonic() - self._created)
        self._started.add_done_callback(started)

    def submit(self, fn: Callable, /, *args, **kwargs) -> Future:
        """Run ``fn(*args, **kwargs)`` in the child; its Future (raises what ``fn`` raised, or
        ``BrokenProcessPool`` when the child died)."""
        return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self) -> None:
        """Cancel the jobs not started and end the child (a running job is abandoned)."""
        processes = list(getattr(self._pool, '_processes', {}).values())  # the pinned Python's pool
        self._pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            if process.is_alive():
                process.terminate()
        for process in processes:
            process.join(timeout=5.0)
