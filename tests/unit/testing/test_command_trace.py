"""The command path's drive-target hops (rrps_testing.command_trace.hops) on a stream whose timing
is known: a teleop stream at 200 Hz, each command received 0.3 ms after its stamp, followed by
the driver's jerk-limited setpoints stepped at every 2 ms SYNC."""

from __future__ import annotations

import numpy as np

from rrps_description.geometry import load_robot
from rrps_hardware.setpoints import JerkLimitedSetpoints
from rrps_interfaces.kinematics import ACTUATORS_COMMAND, POSE, TARGET_POSE
from rrps_interfaces.teleop import MASTER_POSE
from rrps_testing.command_trace import hops, percentiles

PERIOD, SYNC, DELAY = 0.005, 0.002, 0.0003


class Records:
    """What the operator probe would have recorded: (receipt, stamp, leg_1 length) per command."""

    def __init__(self, commands: np.ndarray):
        self.rows = {ACTUATORS_COMMAND: commands, MASTER_POSE: np.empty((0, 3)), TARGET_POSE: np.empty((0, 3)),
                     POSE: np.empty((0, 3))}

    def between(self, topic, t0, t1):
        rows = self.rows[topic]
        return rows[(rows[:, 0] >= t0) & (rows[:, 0] <= t1)] if len(rows) else rows


def test_a_command_reaches_the_drive_one_command_period_late_and_within_a_sync_of_the_next_command():
    """The setpoints interpolate one command period behind the stream: a command's length is a
    drive target about one period (5 ms) after it arrives, and about when the next command
    arrives (derived: the parabola through the last commands is evaluated one period back, at
    each SYNC): within a SYNC at the median; their steering to the stream (a position error over
    the speed) adds less than another SYNC at p99. This is the floor of the hops with no
    transport or scheduling delay."""
    legs = load_robot('pole_climber').motion_limits.legs
    stamps = np.arange(0.0, 4.0, PERIOD)
    lengths = 0.425 + 0.01 * np.sin(2 * np.pi * 0.5 * stamps)[:, None] * np.ones(6)
    gen = JerkLimitedSetpoints(legs, lengths[0])
    k, targets = 0, []
    for t in np.arange(SYNC, 4.0, SYNC):
        while k < len(stamps) and stamps[k] + DELAY <= t:
            gen.command(lengths[k], stamps[k] + DELAY, stamps[k])
            k += 1
        targets.append((t, gen.step(t, SYNC)[0]))
    commands = np.column_stack([stamps + DELAY, stamps, lengths[:, 0]])
    out = hops(Records(commands), 1.5, 3.9, np.array(targets))   # past the start from rest
    n, p50, p99, _, mx = percentiles(out['IK -> drive target'])
    assert n > 0.9 * 2.2 / PERIOD and (PERIOD - SYNC) * 1e3 <= p50 <= (PERIOD + SYNC) * 1e3, (n, p50)
    n, p50, p99, _, mx = percentiles(out['next command -> drive target'])
    # counted where leg_1 moves at a quarter of its peak speed or more: |cos| >= 0.25, 84 % of a sine
    assert n > 0.75 * 2.2 / PERIOD and -SYNC * 1e3 <= p50 <= SYNC * 1e3 and p99 <= 2 * SYNC * 1e3, (n, p50, p99, mx)
