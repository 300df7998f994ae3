#!/usr/bin/env python3
"""Fault report: what the robot does under each fault of a two-host deployment, in one table.

    python benchmarks/fault_report.py [--loopback] [--only NAME[,NAME...]] [--log-dir DIR]

The scenarios and the table are :mod:`rrps_testing.fault_report`; what each fault is and how it
is judged: docs/measurements.md, "Faults of a two-host deployment". tests/system/test_fault_report.py
runs a few of them.
"""

import sys

from rrps_testing.fault_report import main

if __name__ == '__main__':
    sys.exit(main())
