"""The load harness (rrps_testing.load) cleans up after itself, also when its owner is killed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from rrps_runtime.supervision import process_alive

_OWNER = """
import time
from rrps_testing.load import Load
load = Load(busy=1, flood_rate=0.0, quiet=True).start()
print(' '.join(str(p.pid) for p in load.processes), flush=True)
time.sleep(120)
"""



def test_the_load_processes_die_with_a_killed_owner():
    owner = subprocess.Popen([sys.executable, '-c', _OWNER], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in owner.stdout.readline().split()]
        assert pids and all(process_alive(p) for p in pids)
        os.kill(owner.pid, signal.SIGKILL)  # no clean-up code of the owner runs
        owner.wait(timeout=10)
        deadline = time.monotonic() + 10.0
        while any(process_alive(p) for p in pids) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(process_alive(p) for p in pids), 'a load process outlived its owner'
    finally:
        if owner.poll() is None:
            owner.kill()
            owner.wait()
