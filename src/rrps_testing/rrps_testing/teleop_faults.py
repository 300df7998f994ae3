"""The teleoperation faults of the fault report, each run on a
:class:`rrps_testing.fault_session.Session`: a lost link, a silent deadman, a long round trip, a
killed process, and a sender whose clock is off (then its stream cut or late)."""

from __future__ import annotations

import math
import signal
import sys
import time

import numpy as np

from rrps_description.geometry import load_robot
from rrps_interfaces.kinematics import IkStatus
from rrps_testing.fault_metrics import teleop
from rrps_testing.fault_scenarios import activate
from rrps_testing.fault_session import DEADLINE, LINK_DOWN, SENDER, Row, Session
from rrps_testing.netns import wait

# --- teleoperation faults -------------------------------------------------------------------

def engage(s: Session) -> bool:
    s.operator.send({'deadman': True})
    t = time.time()
    return wait(lambda: s.engaged_and_moving(t), DEADLINE)


def teleop_faults(s: Session, wanted: list[str]) -> list[Row]:
    rows = []
    for fault in wanted:
        if fault.startswith('clock'):
            rows.append(clock_fault(s, fault))
            continue
        if not engage(s):
            print(f'{fault}: teleop did not engage:\n{s.logs()}', file=sys.stderr)
            rows.append(Row(fault, note='not run: teleop did not engage (logs on stderr)'))
            continue
        rows.append(TELEOP[fault](s))
    s.operator.send({'deadman': False})
    return rows


def teleop_link(s: Session) -> Row:
    row = Row('link down 2 s during teleop')
    t_down = s.rig.link(False)
    time.sleep(LINK_DOWN)
    t_up = s.rig.link(True)
    row.detected = 'teleop ' + ', '.join(s.teleop_codes(t_down, t_up))
    ok = wait(lambda: s.engaged_and_moving(t_up), DEADLINE)
    row.recovery = f'none: the held deadman re-engages ({s.clutch(t_up, row)})'
    row.recovered = ok
    return s.measure(row, t_down, t_up)


def teleop_deadman_silent(s: Session) -> Row:
    row = Row('deadman stream stops (no release)')
    t_fault = time.time()
    s.operator.send({'deadman': False, 'silent': True})
    time.sleep(LINK_DOWN)
    row.detected = 'teleop ' + ', '.join(s.teleop_codes(t_fault, time.time()))
    t_press = time.time()
    s.operator.send({'deadman': True})
    ok = wait(lambda: s.engaged_and_moving(t_press), DEADLINE)
    row.recovery = f'operator presses the deadman again ({s.clutch(t_press, row)})'
    row.recovered = ok
    return s.measure(row, t_fault, t_press)


def teleop_round_trip(s: Session, rtt: float) -> Row:
    row = Row(f"operator's round trip {rtt * 1e3:.0f} ms for 2 s")
    t_fault = time.time()
    s.operator.send({'round_trip': rtt})
    time.sleep(LINK_DOWN)
    t_end = time.time()
    s.operator.send({'round_trip': None})
    statuses = [teleop(r) for r in s.operator.records('teleop/status', t_fault + 0.5, t_end)]
    factors = sorted({round(x.speed_factor, 2) for x in statuses if x.engaged})
    row.detected = 'teleop ' + ', '.join(s.teleop_codes(t_fault + 0.5, t_end, engaged=True)
                                         + s.teleop_codes(t_fault + 0.5, t_end))
    if factors:
        row.detected += f' (speed x {", ".join(map(str, factors))})'
    # the last round trip expires 1 s after its last report
    ok = wait(lambda: (x := s.teleop_status(t_end + 1.0)) is not None and x.engaged
              and x.speed_factor == 1.0, DEADLINE)
    if all(x.engaged for x in statuses):  # slowed, not held
        s.measure(row, t_fault, t_end)
        row.hold_s = None
        row.note = 'slowed, not held'
        row.recovery = 'none: full speed again once the round trip is back'
    else:
        s.measure(row, t_fault, t_end)
        row.recovery = f'none: the held deadman re-engages ({s.clutch(t_end + 1.0, row)})'
    row.recovered = ok
    return row


def teleop_kill(s: Session, name: str) -> Row:
    row = Row(f'kill {name.replace("_", " ")} process during teleop')
    t_kill = time.time()
    s.rig.signal(name, signal.SIGKILL)
    time.sleep(1.0)
    t_restart = time.time()
    if name == 'driver':
        s.start_driver()
        wait(lambda: (x := s.teleop_status(t_restart)) is not None and x.code.name == 'DRIVER_INACTIVE',
             DEADLINE)
        row.detected = ('teleop ' + ', '.join(s.teleop_codes(t_kill, t_restart))
                        + ', then DRIVER_INACTIVE')
        wait(lambda: s.robot.records('actuators/state', t_restart), DEADLINE)
        row.note = f'resumed {s.resumed_offset_mm(t_kill, t_restart):.2f} mm from its last state'
        t_action = time.time()
        activated = activate(s)
        row.recovery = 'restart the driver (inactive, state file); operator activates it; deadman clutch'
    elif name == 'robot_nodes':
        s.start_robot_nodes()
        row.detected = 'teleop ' + ', '.join(s.teleop_codes(t_kill, t_restart))
        t_action, activated = t_restart, True
        row.recovery = 'restart the robot nodes; the held deadman engages as a clutch'
    else:
        s.start_operator()
        row.detected = 'no more targets (teleop is gone): the IK and the driver time out'
        t_action, activated = t_restart, True
        row.recovery = 'restart the operator station; a fresh deadman engages as a clutch'
    ok = activated and wait(lambda: s.engaged_and_moving(t_action), DEADLINE)
    row.recovered = ok
    if ok:
        row.recovery += f' ({s.clutch(t_action, row)})'
    return s.measure(row, t_kill, t_action, commands_until=t_restart if name == 'driver' else None)


TELEOP = {
    'teleop_link': teleop_link,
    'teleop_deadman_silent': teleop_deadman_silent,
    'teleop_rtt_250': lambda s: teleop_round_trip(s, 0.25),
    'teleop_rtt_400': lambda s: teleop_round_trip(s, 0.4),
    'teleop_kill_driver': lambda s: teleop_kill(s, 'driver'),
    'teleop_kill_robot_nodes': lambda s: teleop_kill(s, 'robot_nodes'),
    'teleop_kill_operator': lambda s: teleop_kill(s, 'operator'),
}


def ik_counts(s: Session, since: float = -math.inf) -> tuple[int, int] | None:
    """ik_node's (accepted, rejected) targets from its newest /diagnostics status."""
    rows = [r for r in s.robot.records('/diagnostics', since) if r['node'] == 'ik_node']
    if not rows:
        return None
    status = IkStatus.from_values(rows[0 if math.isfinite(since) else -1]['values'])
    return status.accepted, status.rejected


def clock_fault(s: Session, fault: str) -> Row:
    """A sender whose clock is 2 s off streams targets; then its stream is cut (or late)."""
    offset = -2.0 if fault == 'clock_behind' else 2.0
    s.operator.send({'deadman': False})
    t = time.time()
    wait(lambda: (x := s.teleop_status(t)) is not None and not x.engaged, DEADLINE)
    sender = {**SENDER, 'offset': offset}
    t0 = time.time()
    s.operator.send({'sender': sender})
    # followed: commands come, and the robot reached the sender's targets (around the home
    # pose, 4 mm up and down; teleop may have left it a few centimetres away)
    home = load_robot('pole_climber').home_position
    followed = wait(lambda: len(s.robot.records('actuators/command', t0 + 1.0)) > 20
                    and (p := s.robot.records('pose', time.time() - 0.5))
                    and max(np.linalg.norm(np.subtract(r['p'], home)) for r in p) < 0.005, DEADLINE)
    if fault == 'clock_late':
        row = Row('sender clock +2 s, its targets 0.3 s late for 2 s')
        before = ik_counts(s)
        t_fault = time.time()
        s.operator.send({'sender_late': 0.3})
        time.sleep(LINK_DOWN)
        t_back = time.time()
        s.operator.send({'sender_late': 0.0})
        commands = s.robot.records('actuators/command', t_fault, t_back)
        # the commands stop (late targets refused) until the delay is learned as a clock offset
        gaps = np.diff([t_fault] + [c['t'] for c in commands] + [t_back])
        k = int(np.argmax(gaps))
        t_held, t_again = ([t_fault] + [c['t'] for c in commands])[k], t_fault + float(np.sum(gaps[:k + 1]))
        resumed = wait(lambda: len(s.robot.records('actuators/command', t_back + 2.0)) > 10, DEADLINE)
        wait(lambda: ik_counts(s, t_back), 10.0)
        after = ik_counts(s, t_back)  # its first status after the delay ended
        refused = '?' if before is None or after is None else after[1] - before[1]
        if gaps[k] < 0.15:
            row.detected = f'late targets acted on (ik_node refused {refused})'
        else:
            row.detected = (f'ik_node refused {refused} targets as late; after {t_again - t_fault:.1f} s '
                            'a lasting delay looks like a clock offset and is learned (the '
                            'documented limit)')
        row.recovery = 'none: on time again, the stream goes on'
        row.recovered = followed and resumed
        s.operator.send({'sender': None})
        s.measure(row, t_fault, t_again, commands_until=t_held + 1e-3)
        return row
    row = Row(f'sender clock {offset:+.0f} s, its stream cut 2 s')
    if s.rig.can_cut_link:
        t_cut = s.rig.link(False)
        time.sleep(LINK_DOWN)
        t_back = s.rig.link(True)
    else:
        s.operator.send({'sender': None})
        t_cut = time.time()
        time.sleep(LINK_DOWN)
        s.operator.send({'sender': sender})
        t_back = time.time()
    resumed = wait(lambda: len(s.robot.records('actuators/command', t_back + 0.3)) > 10, DEADLINE)
    s.operator.send({'sender': None})
    row.detected = 'followed the offset clock' if followed else 'never followed the stream'
    row.detected += '; the IK and the driver time out'
    row.recovery = 'none: the stream resumes (its clock offset is learned)'
    row.recovered = followed and resumed
    return s.measure(row, t_cut, t_back)
