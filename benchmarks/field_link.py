#!/usr/bin/env python3
"""Field links: the operator link's profiles and a fleet's scale, on network namespaces (root).

    python benchmarks/field_link.py [--profiles clean,2M,500k_loss,outages] [--fleet 1,3,6]
                                    [--skip-profiles] [--skip-fleet] [--log-dir DIR]

**Profiles** (rrps_testing.field_link): the two-host split of docs/deployment.md (driver at 500 Hz, master at
200 Hz), teleop engaged for 12 s on the master's circle, then a climbing step, on each link
profile: clean; 2 Mbit/s robot -> operator and 500 kbit/s back; 500 kbit/s each way with 5 %
random loss; 2 Mbit/s and 500 kbit/s back with a 1 s outage every 10 s. Three operator-station
patterns in the same run:

* ``old``: teleop and viewer read the robot's own topics (the 500 Hz streams cross the link) and
  teleop commands once per master sample (200 Hz): the baseline;
* ``link``: the link relay on the robot host, teleop and viewer on its link topics, teleop's
  commands at 50 Hz (the documented link profile);
* ``link, 200 Hz commands``: the link relay, commands once per master sample (2M only): what the
  command stream alone costs the back link.

Each row: bytes per second each way (veth counters), the slave's motion, teleop's slave-state
age p50/p99 while engaged, the teleop codes, the viewer's pose rate, the climbing step, MET or
MISSED against the targets (follows without a spurious disengagement, age p99 < 100 ms, viewer
>= 10 Hz, no jump, no gripper opening on a lost link, the climb ends idle).

**Fleet** (rrps_testing.fleet_rig): 1, 3 and 6 robots (driver 50 Hz, IK, FK, climbing, link relay
and flight recorder each) and one operator station on a bridge; robot 1 driven for 10 s:
discovery time (operator station started -> its viewer heard every robot), the operator
station's CPU, the viewer's pose and draw rates, link kbit/s of the driven robot and the mean of
the others.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

from rrps_testing.ci import next_domain_id
from rrps_testing.field_link import PROFILES, FieldSession
from rrps_testing.fleet_rig import Fleet, FleetRig
from rrps_testing.link_shaping import nft_available
from rrps_testing.netns import netns_supported
from rrps_testing.netns_rig import Rig

#: name -> (FieldSession pattern, teleop command rate (None: per master sample), profiles)
PATTERNS = {
    'old': ('direct', None, None),
    'link': ('link', 50.0, None),
    'link, 200 Hz commands': ('link', None, ('2M',)),
}


def _kbit(value: float) -> str:
    return '—' if value is None or math.isnan(value) else f'{value / 1e3:.0f}'


def _ms(value) -> str:
    return '—' if value is None else f'{value:.0f}'


def profile_rows(names: list[str], log_dir: Path) -> list[str]:
    rows = ['| profile | pattern | robot→op kbit/s | op→robot kbit/s | slave motion [mm] | age p50/p99 [ms] '
            '| teleop codes | disengaged: link / own stalls | viewer pose Hz | climbing step | targets |',
            '|---|---|---|---|---|---|---|---|---|---|---|']
    for label, (pattern, command_rate, only) in PATTERNS.items():
        wanted = [n for n in names if only is None or n in only]
        if not wanted:
            continue
        with Rig(next_domain_id(), discovery='subnet', log_dir=log_dir) as rig:
            session = FieldSession(rig, pattern, driver_rate=500.0, master_rate=200.0, command_rate=command_rate)
            for name in wanted:
                r = session.run(PROFILES[name], teleop_time=12.0)
                viewer = '—' if r.viewer_rate is None else f'{r.viewer_rate:.0f}'
                row = (f'| {PROFILES[name].name} | {label} | {_kbit(r.robot_to_operator)} | '
                       f'{_kbit(r.operator_to_robot)} | {r.motion_mm:.1f} | {_ms(r.age_p50)}/{_ms(r.age_p99)} | '
                       f'{", ".join(r.codes)} | {r.spurious} / {r.stalls} | {viewer} | {r.climb or "—"} | '
                       f'{"MET" if r.met() else "MISSED"} |')
                print(row, flush=True)
                rows.append(row)
    return rows


def fleet_rows(counts: list[int], log_dir: Path) -> list[str]:
    rows = ['| robots | discovery [s] | operator CPU [% of a core] | viewer pose / draw Hz | '
            'driven robot kbit/s (out/in) | other robots kbit/s (out/in, mean) |',
            '|---|---|---|---|---|---|']
    for n in counts:
        with FleetRig(next_domain_id(), n, log_dir=log_dir) as rig:
            fleet = Fleet(rig, robot_agents=False)
            discovery = fleet.wait_up()
            fleet.operator.send({'deadman': True})
            time.sleep(2.0)
            b0, c0, t0 = fleet.bytes(), fleet.operator_cpu(), time.time()
            time.sleep(10.0)
            b1, c1, t1 = fleet.bytes(), fleet.operator_cpu(), time.time()
            viewer = fleet.viewer_status(t1 - 2.0)
            fleet.operator.send({'deadman': False})
        rates = {ns: tuple(8e-3 * (b1[ns][i] - b0[ns][i]) / (t1 - t0) for i in (0, 1)) for ns in b0}
        driven = rates[fleet.namespaces[0]]
        others = [rates[ns] for ns in fleet.namespaces[1:]]
        other = (f'{statistics.mean(o[0] for o in others):.0f}/{statistics.mean(o[1] for o in others):.0f}'
                 if others else '—')
        rate = '—' if viewer is None else f'{viewer.pose_rate:.0f} / {viewer.draw_rate:.0f}'
        row = (f'| {n} | {discovery:.1f} | {100.0 * (c1 - c0) / (t1 - t0):.0f} | {rate} | '
               f'{driven[0]:.0f}/{driven[1]:.0f} | {other} |')
        print(row, flush=True)
        rows.append(row)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--profiles', default='clean,2M,500k_loss,outages')
    p.add_argument('--fleet', default='1,3,6')
    p.add_argument('--skip-profiles', action='store_true')
    p.add_argument('--skip-fleet', action='store_true')
    p.add_argument('--log-dir', type=Path, default=None)
    args = p.parse_args(argv)
    for ok, reason in (netns_supported(), nft_available()):
        if not ok:
            print(f'field_link: {reason}', file=sys.stderr)
            return 2
    unknown = [n for n in args.profiles.split(',') if n not in PROFILES]
    if unknown:
        print(f'field_link: unknown profiles {unknown}; known: {", ".join(PROFILES)}', file=sys.stderr)
        return 2
    log_dir = args.log_dir or Path(tempfile.mkdtemp(prefix='rrps-field-link-'))
    print(f'logs in {log_dir}\n', flush=True)
    tables = []
    if not args.skip_profiles:
        tables.append(profile_rows(args.profiles.split(','), log_dir))
    if not args.skip_fleet:
        tables.append(fleet_rows([int(n) for n in args.fleet.split(',')], log_dir))
    print()
    for table in tables:
        print('\n'.join(table) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
