"""The fault report (rrps_testing.fault_report, benchmarks/fault_report.py) in reduced form: two
faults on the two-host rig (loopback without root), one table, and the numbers it reports hold up.

The operator station's process is killed during teleoperation and restarted (the robot holds
at once and a fresh deadman engages as a clutch), and a sender whose clock is 2 s behind this
host's streams targets that the robot follows until the stream is cut (it holds within the
command timeout, not 2 s off).
"""

from __future__ import annotations

import math

import pytest

from rrps_testing import fault_report as report
from rrps_testing.netns import netns_supported

pytestmark = [pytest.mark.ros, pytest.mark.slow]

def test_the_fault_report_runs_and_its_rows_show_safe_holds(ros_domain_id, tmp_path, capsys):
    rows = report.run_report(only=['teleop_kill_operator', 'clock_behind'], domain_id=ros_domain_id,
                             loopback=not netns_supported()[0], log_dir=tmp_path)
    text = report.table(rows)
    print(text)
    assert [r.fault for r in rows] == ['kill operator process during teleop',
                                       'sender clock -2 s, its stream cut 2 s'], text
    for row in rows:
        assert row.recovered, text
        assert row.openings == 0, text
        # the commands stop within the command timeout (+ a slow tick on a busy machine) ...
        assert row.hold_s is not None and 0.0 <= row.hold_s <= 0.5, text
        # ... and nothing moves once held (from when the actuators' lag settled)
        assert row.held_motion_mm is not None and row.held_motion_mm < 0.02, text
        assert math.isfinite(row.motion_mm) and row.motion_mm < 3.0, text
    assert rows[0].recovery.startswith('restart the operator station')
    jump, allowed = rows[0].clutch_mm  # re-engaging is a clutch: no jump
    assert jump <= allowed, text
    assert rows[1].detected.startswith('followed the offset clock'), text
    lines = text.splitlines()
    assert [c.strip() for c in lines[0].strip('|').split('|')] == list(report.HEAD)
    assert len(lines) == 4 and all(line.count('|') == len(report.HEAD) + 1 for line in lines), text
