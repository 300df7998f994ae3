"""Helpers shared by the benchmarks that start the installed nodes."""

from __future__ import annotations

import signal
import subprocess
import time


def wait_until(predicate, timeout: float) -> bool:
    """Poll ``predicate`` every 10 ms until it is truthy (True) or ``timeout`` s pass (False)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return False


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
