"""Child processes that never outlive their supervisor, their scheduling, and a clean way to stop them.

:func:`start_child` (SIGTERM to the child when this process dies), :func:`stop_child` (SIGTERM once, then SIGKILL) and
:class:`Respawner`; the priorities below, and why a prioritised child leads its own session (Linux autogroup):
docs/deployment.md, "Process layout and priorities" and "Supervision". Pure Python, no ROS import.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Sequence

__all__ = ['SHUTDOWN_DEADLINE', 'STOP_GRACE',
           'PARENT_PID_ENV', 'CONTROL_NICE', 'CONTROL_RT_PRIORITY', 'OPERATOR_NICE', 'OPERATOR_RT_PRIORITY',
           'OBSERVER_NICE', 'start_child', 'priority_of', 'group_priority_of', 'set_group_priority', 'scheduling_of',
           'raise_priority',
           'stop_child', 'stop_children', 'terminate_children', 'hurry', 'wait_children', 'exit_with_parent',
           'die_with_parent', 'Respawner', 'process_alive',
           'child_pids']

#: Environment variable through which a child learns its supervisor's pid.
PARENT_PID_ENV = 'RRPS_PARENT_PID'

_PR_SET_PDEATHSIG = 1

#: Nice value of the robot's command path (driver; IK, FK, climbing) where real-time
#: scheduling is not permitted, and under it (the value a normal policy returns to).
CONTROL_NICE = -10
#: SCHED_RR priority of the robot's command path: above every normal process, below the
#: kernel's interrupt threads (priority 50).
CONTROL_RT_PRIORITY = 10
#: Nice value of the operator station (master, teleop, viewer): before other jobs, after the robot.
OPERATOR_NICE = -5
#: SCHED_RR priority of the operator station: ahead of normal processes (the browser, other
#: jobs), behind the robot's command path.
OPERATOR_RT_PRIORITY = 5
#: Nice value of observers (recorder, markers): the normal priority, below the command path's
#: real time (at nice 5 the flight recorder started too late on a loaded machine: docs/deployment.md).
OBSERVER_NICE = 0


def raise_priority(nice: int, *, realtime: int | None = None) -> bool:
    """Set this process's nice value and, with ``realtime``, SCHED_RR at that priority (else the normal policy); a
    session leader also sets its autogroup's nice value. False when not permitted (root or CAP_SYS_NICE needed): the
    process then keeps what it was allowed."""
    niced = realtime_set = True
    try:
        os.setpriority(os.PRIO_PROCESS, 0, nice)
    except (PermissionError, OSError):  # without CAP_SYS_NICE: an RLIMIT_NICE allowance
        niced = False
    if realtime is not None:
        try:  # without CAP_SYS_NICE: an RLIMIT_RTPRIO allowance (ulimit -r)
            os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(realtime))
        except (PermissionError, OSError):
            realtime_set = False
    elif os.sched_getscheduler(0) != os.SCHED_OTHER:  # e.g. a child of a real-time supervisor
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    if niced:
        try:
            set_group_priority(os.getpid(), nice)
        except OSError:  # no autogroup in this kernel, or not permitted: the nice value stands
            pass
    return niced and realtime_set


def set_group_priority(pid: int, nice: int) -> None:
    """The autogroup nice value of process ``pid``'s session, when ``pid`` leads it (OSError: no
    autogroup in this kernel, or not permitted)."""
    if os.getsid(pid) == pid:
        with open(f'/proc/{pid}/autogroup', 'w') as f:
            f.write(str(nice))


def scheduling_of(pid: int) -> str:
    """How process ``pid`` is scheduled, for people: ``'SCHED_RR 10'`` or ``'nice -10'``."""
    if os.sched_getscheduler(pid) & ~getattr(os, 'SCHED_RESET_ON_FORK', 0) == os.SCHED_RR:  # a claimed thread's flag
        return f'SCHED_RR {os.sched_getparam(pid).sched_priority}'
    return f'nice {priority_of(pid)}'


def group_priority_of(pid: int) -> int | None:
    """The autogroup nice value of process ``pid``'s session; None without autogroup."""
    try:
        with open(f'/proc/{pid}/autogroup') as f:
            return int(f.read().split()[-1])
    except (OSError, ValueError, IndexError):
        return None


def priority_of(pid: int) -> int:
    """The nice value of a process."""
    return os.getpriority(os.PRIO_PROCESS, pid)


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (Linux /proc)."""
    try:
        with open(f'/proc/{pid}/stat') as f:
            return f.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except OSError:
        return False


def child_pids(pid: int) -> list[int]:
    """The pids of the processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for entry in os.listdir('/proc'):
        if entry.isdigit():
            try:
                with open(f'/proc/{entry}/stat') as f:
                    if int(f.read().rsplit(')', 1)[1].split()[1]) == pid:
                        out.append(int(entry))
            except (OSError, ValueError):
                continue
    return out


def die_with_parent(parent: int) -> None:
    """In a child (before exec, or a worker process at its start): ask the kernel for SIGTERM
    when the parent ``parent`` dies."""
    if sys.platform.startswith('linux'):
        libc = ctypes.CDLL(ctypes.util.find_library('c') or 'libc.so.6', use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)


def start_child(args: Sequence[str], *, env: dict | None = None, nice: int | None = None,
                realtime: int | None = None, **popen_kwargs) -> subprocess.Popen:
    """``subprocess.Popen(args)`` of a child that receives SIGTERM when this process dies, with ``nice`` and the
    SCHED_RR priority ``realtime`` if given (as permitted: :func:`raise_priority`), then in a session of its own.

    Must be called from the main thread (RuntimeError otherwise: the kernel ties the signal to the forking thread).
    """
    if threading.current_thread() is not threading.main_thread():
        raise RuntimeError('start_child must be called from the main thread')
    parent = os.getpid()
    child_env = dict(os.environ if env is None else env)
    child_env[PARENT_PID_ENV] = str(parent)

    def prepare() -> None:
        die_with_parent(parent)
        if nice is not None or realtime is not None:
            if os.getsid(0) != os.getpid():
                os.setsid()
            raise_priority(priority_of(0) if nice is None else nice, realtime=realtime)
    return subprocess.Popen(list(args), env=child_env, preexec_fn=prepare, **popen_kwargs)


#: Longest a node process takes to end [s] from its first stop request (a signal, its supervisor's death):
#: past it every thread's stack is printed to stderr and it exits with status 1 (rrps_runtime.process).
SHUTDOWN_DEADLINE = 10.0
#: A supervisor's SIGKILL comes this long [s] after its SIGTERM: after the child's own deadline, so that a
#: stuck child prints its stacks first and a child finishing its work (a flight record) is not cut short.
STOP_GRACE = SHUTDOWN_DEADLINE + 1.0


def stop_child(process: subprocess.Popen, timeout: float = STOP_GRACE) -> int:
    """SIGTERM, wait up to ``timeout`` s, then SIGKILL; returns the exit status."""
    return stop_children([process], timeout)[0]


def stop_children(processes: Sequence[subprocess.Popen], timeout: float = STOP_GRACE) -> list[int]:
    """:func:`stop_child` for several processes at once (they stop in parallel)."""
    terminate_children(processes)
    return wait_children(processes, timeout)


def terminate_children(processes: Sequence[subprocess.Popen]) -> None:
    """SIGTERM to each process still running. Send it once: a process shutting down after a SIGTERM (closing
    a recording, keeping its hardware's state) may treat a second one as "give up". A process niced below the
    normal priority (an observer) is first put back at nice 0 to shut down (:func:`hurry`)."""
    for process in processes:
        if process.poll() is None:
            hurry(process.pid)
            try:
                process.send_signal(signal.SIGTERM)
            except ProcessLookupError:
                pass


def hurry(pid: int) -> None:
    """Process ``pid`` back at nice 0 (every thread, and its autogroup when it leads a session) if it
    runs niced below it, where permitted: an observer that runs best-effort still closes its files
    within its supervisor's stop timeout on a busy machine (at nice 5 under load it did not in 5 s)."""
    try:
        if os.getpriority(os.PRIO_PROCESS, pid) <= 0:
            return
        for tid in os.listdir(f'/proc/{pid}/task'):
            os.setpriority(os.PRIO_PROCESS, int(tid), 0)
        set_group_priority(pid, 0)
    except (OSError, ValueError):  # gone meanwhile, no autogroup, or not permitted: it stops as it is
        pass


def wait_children(processes: Sequence[subprocess.Popen], timeout: float) -> list[int]:
    """Wait up to ``timeout`` s for the processes to end, then SIGKILL the rest; their exit statuses."""
    deadline = time.monotonic() + timeout
    for process in processes:
        try:
            process.wait(max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    return [process.returncode for process in processes]


def exit_with_parent(on_exit, *, period: float = 0.5) -> threading.Thread | None:
    """In a child started by :func:`start_child`: call ``on_exit()`` once its supervisor is gone.

    A portable second line behind ``PR_SET_PDEATHSIG``: a daemon thread polls the parent pid.
    Returns the thread, or None when this process was not started by :func:`start_child`.
    """
    value = os.environ.pop(PARENT_PID_ENV, None)  # not inherited by this process's own children
    if not value:
        return None
    parent = int(value)

    def watch() -> None:
        while True:
            if os.getppid() != parent:
                on_exit()
                return
            time.sleep(period)

    thread = threading.Thread(target=watch, name='exit-with-parent', daemon=True)
    thread.start()
    return thread


class Respawner:
    """Children restarted when they die, as a launch file's ``respawn``: ``starters`` maps a name to
    ``start(first: bool) -> Popen``; beyond ``max_restarts`` per ``window`` s a child is given up and left dead.
    Call :meth:`poll` periodically from the main thread."""

    def __init__(self, starters, *, max_restarts: int = 3, window: float = 60.0):
        self.starters = dict(starters)
        self.max_restarts = max_restarts
        self.window = window
        self.children = {name: start(True) for name, start in self.starters.items()}
        self._restarts: dict[str, list[float]] = {name: [] for name in self.starters}
        self.given_up: set[str] = set()
        self._stopping = False

    def poll(self) -> list[tuple[str, int | None, bool]]:
        """(name, exit status, restarted) for every child found dead since the last call (none once
        :meth:`terminate` was called: the children are being stopped)."""
        if self._stopping:
            return []
        events = []
        now = time.monotonic()
        for name, child in list(self.children.items()):
            if name in self.given_up or child.poll() is None:
                continue
            recent = [t for t in self._restarts[name] if now - t < self.window]
            if len(recent) >= self.max_restarts:
                self.given_up.add(name)
                events.append((name, child.returncode, False))
                continue
            self._restarts[name] = recent + [now]
            self.children[name] = self.starters[name](False)
            events.append((name, child.returncode, True))
        return events

    def terminate(self) -> None:
        """SIGTERM to every child not sent one yet; no restart from here on (:meth:`stop` waits for them)."""
        if not self._stopping:   # the children are fixed from here on: poll() restarts none
            self._stopping = True
            terminate_children(list(self.children.values()))

    def stop(self, timeout: float = STOP_GRACE) -> list[int]:
        """Stop every child: SIGTERM (once, :meth:`terminate`), then SIGKILL after ``timeout`` s."""
        self.terminate()
        return wait_children(list(self.children.values()), timeout)
