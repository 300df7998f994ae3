"""The recorder benchmark's control: a process that only burns CPU, no ROS, no I/O.

Busy for ``duty`` of every 10 ms, asleep for the rest: the same share of a core as the process
it stands in for, to tell what any process of that CPU adds to the stack's (contention on a
shared 2-core machine) from what the recorder itself makes the stack do.

    python benchmarks/_cpu_load.py 0.065
"""

from __future__ import annotations

import sys
import time

PERIOD = 0.01


def main() -> None:
    duty = float(sys.argv[1])
    if not 0.0 < duty < 1.0:
        raise SystemExit(f'duty must be in (0, 1), got {duty}')
    try:
        while True:
            start = time.perf_counter()
            while time.perf_counter() - start < duty * PERIOD:
                pass
            time.sleep(PERIOD * (1.0 - duty))
    except KeyboardInterrupt:
        pass


if __name__ == '__main__':
    main()
