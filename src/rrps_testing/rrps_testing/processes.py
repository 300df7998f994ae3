"""Helpers shared by the benchmarks and tests that start the installed nodes."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import time
from pathlib import Path

from rrps_runtime.supervision import set_group_priority

_TICK = os.sysconf('SC_CLK_TCK')


def cpu_seconds(pids) -> float:
    """User + system CPU seconds of the processes ``pids`` so far, from /proc/<pid>/stat (0 for
    one that is gone)."""
    total = 0.0
    for pid in pids:
        try:
            fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
        except OSError:
            continue
        total += (int(fields[11]) + int(fields[12])) / _TICK
    return total


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago (for a server a test starts)."""
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def descendants(pid: int) -> list[int]:
    """The processes below ``pid`` (its children, theirs, ...), from the parent ids in /proc/<pid>/stat."""
    parents: dict[int, list[int]] = {}
    for entry in os.listdir('/proc'):
        if not entry.isdigit():
            continue
        try:
            ppid = int(Path(f'/proc/{entry}/stat').read_text().rsplit(')', 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        parents.setdefault(ppid, []).append(int(entry))
    found, todo = [], [pid]
    while todo:
        children = parents.get(todo.pop(), [])
        found += children
        todo += children
    return found


def raise_tree_priority(pid: int, nice: int) -> list[int]:
    """Give every session led by ``pid`` or one of its descendants the autogroup nice value ``nice``
    (a child that starts a session of its own, as Playwright's browser does, leaves its parent's
    autogroup and with it the parent's weight); returns those session leaders (root needed for a
    negative ``nice``). Sessions are weighed against each other by their autogroups, whatever the
    nice values of their threads."""
    done = []
    for p in [pid, *descendants(pid)]:
        try:
            if os.getsid(p) != p:
                continue
            set_group_priority(p, nice)
        except OSError:  # gone meanwhile, no autogroup in this kernel, or not permitted
            continue
        done.append(p)
    return done


def wait_until(predicate, timeout: float) -> bool:
    """Poll ``predicate`` every 10 ms until it is truthy (True) or ``timeout`` s pass (False)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return False


def interrupt(process: subprocess.Popen, timeout: float = 60.0) -> None:
    """Ctrl-C ``process`` if it still runs (SIGINT, as an operator stops the demo); kill it if it
    has not stopped after ``timeout`` s."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def stop_processes(processes, timeout: float = 5.0) -> None:
    """SIGTERM every process (the nodes' clean shutdown, as Ctrl-C; a SIGINT would be ignored
    by a benchmark started in the background of a non-interactive shell, which passes SIGINT
    ignored to its children), then kill those still running."""
    for p in processes:
        p.send_signal(signal.SIGTERM)
    for p in processes:
        try:
            p.wait(timeout)
        except subprocess.TimeoutExpired:
            p.kill()


def demo_excerpt(out: str, tail: int = 3000) -> str:
    """What a failed headless demo's output tells: every line of its scripted operator and every
    ERROR, the first 20 WARN lines, then the last ``tail`` characters (which alone miss the
    operator's account of a pause on a long run)."""
    lines = out.splitlines()
    said = [line for line in lines if 'rrps demo --headless:' in line or '[ERROR]' in line]
    warnings = [line for line in lines if '[WARN]' in line][:20]
    return '\n'.join(['--- the operator and errors:', *said, '--- the first warnings:', *warnings,
                      '--- the end:', out[-tail:]])
