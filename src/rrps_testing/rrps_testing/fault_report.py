#!/usr/bin/env python3
"""Fault report: what the robot does under each fault of a two-host deployment, in one table.

    python -m rrps_testing.fault_report [--loopback] [--only NAME[,NAME...]] [--log-dir DIR]

The stack runs as deployed (docs/deployment.md): driver and robot nodes on the robot host, master and teleop on
the operator station, and on each host an agent (rrps_testing.netns_agent) that plays the operator and records.
As root the hosts are two network namespaces (rrps_testing.netns_rig); without root, or with ``--loopback``,
both run on loopback and the link faults are left out. The faults (:data:`rrps_testing.fault_session.FAULTS`)
and what each row measures: docs/measurements.md, 'Faults of a two-host deployment'.
tests/system/test_fault_report.py runs :func:`run_report` with a few faults.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from rrps_testing.fault_scenarios import climb_faults, demo_kill
from rrps_testing.fault_session import CLIMB_FAULTS, FAULTS, LINK_FAULTS, TELEOP_FAULTS, Row, Session
from rrps_testing.netns import netns_supported
from rrps_testing.netns_rig import Rig
from rrps_testing.teleop_faults import teleop_faults

# --- the report -----------------------------------------------------------------------------

def run_report(*, only: list[str] | None = None, loopback: bool = False, domain_id: int | None = None,
               log_dir: str | Path | None = None) -> list[Row]:
    """Run the faults (``only``: a subset of FAULTS, in FAULTS' order) and return their rows."""
    wanted = list(FAULTS if not only else only)
    unknown = set(wanted) - set(FAULTS)
    if unknown:
        raise ValueError(f'unknown faults {sorted(unknown)}; known: {", ".join(FAULTS)}')
    isolated = not loopback and netns_supported()[0]
    rows: list[Row] = []
    if not isolated:
        for fault in [f for f in wanted if f in LINK_FAULTS]:
            rows.append(Row(fault, note='not run: cutting a link needs root (network namespaces)'))
        wanted = [f for f in wanted if f not in LINK_FAULTS]
    domain = domain_id if domain_id is not None else 150 + os.getpid() % 50
    climbing = [f for f in wanted if f in CLIMB_FAULTS]
    teleoperating = [f for f in TELEOP_FAULTS if f in wanted]
    state_dir = Path(tempfile.mkdtemp(prefix='rrps-faults-'))
    try:
        if climbing or teleoperating:
            with Rig(domain, discovery='subnet' if isolated else 'loopback', log_dir=log_dir) as rig:
                s = Session(rig, state_dir)
                if climbing:
                    rows += climb_faults(s, climbing)
                if teleoperating:
                    rows += teleop_faults(s, teleoperating)
    finally:
        shutil.rmtree(state_dir, ignore_errors=True)
    if 'demo_kill' in wanted:
        rows.append(demo_kill(domain + 1))
    return rows


HEAD = ('fault', 'time to safe hold', 'motion during fault', 'gripper openings', 'detection',
        'recovery action')


def table(rows: list[Row]) -> str:
    """One Markdown table: a row per fault (HEAD's columns)."""
    def cells(r: Row) -> tuple:
        if r.note and r.hold_s is None and r.motion_mm is None:
            return (r.fault, '', '', '', r.note, '')
        hold = '' if r.hold_s is None else f'{r.hold_s:.2f} s'
        motion = ''
        if r.motion_mm is not None and not math.isnan(r.motion_mm):
            held = ('' if r.held_motion_mm is None or math.isnan(r.held_motion_mm)
                    else f' ({r.held_motion_mm:.3f} mm held)')
            motion = f'{r.motion_mm:.2f} mm{held}'
        return (r.fault + (f' ({r.note})' if r.note else ''), hold or 'n/a', motion,
                '' if r.openings is None else str(r.openings), r.detected,
                r.recovery + ('' if r.recovered is None else ': ok' if r.recovered else ': FAILED'))
    body = [cells(r) for r in rows]
    widths = [max(len(str(x[i])) for x in [HEAD] + body) for i in range(len(HEAD))]

    def fmt(cols) -> str:
        return '| ' + ' | '.join(str(c).ljust(w) for c, w in zip(cols, widths)) + ' |'
    line = '|' + '|'.join('-' * (w + 2) for w in widths) + '|'
    return '\n'.join([fmt(HEAD), line] + [fmt(b) for b in body])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description='rrps fault report (one table)')
    p.add_argument('--only', default='', help=f'comma-separated faults: {", ".join(FAULTS)}')
    p.add_argument('--loopback', action='store_true', help='no network namespaces, even as root')
    p.add_argument('--domain-id', type=int, default=None)
    p.add_argument('--log-dir', default=None, help='keep the processes\' logs there')
    args = p.parse_args(argv)
    only = [f for f in args.only.split(',') if f]
    t0 = time.time()
    rows = run_report(only=only or None, loopback=args.loopback, domain_id=args.domain_id,
                      log_dir=args.log_dir)
    mode = ('two network namespaces joined by a veth pair' if not args.loopback and netns_supported()[0]
            else 'loopback (one host)')
    print(f'rrps fault report: pole climber, driver 100 Hz, {mode}; {time.time() - t0:.0f} s\n')
    print(table(rows))
    print('\ntime to safe hold: from the fault to the last actuators/command published on the robot '
          'host (the driver holds its last command: the IK and the driver refuse commands older '
          'than 0.1 s); motion: largest leg-length change from the fault until the recovery action '
          '(a restarted driver\'s resumed lengths count), in brackets from 0.5 s after the hold '
          'on; gripper openings: closed -> open switches in that time.')
    return 0 if all(r.recovered is not False for r in rows) else 1


if __name__ == '__main__':
    sys.exit(main())
