#!/usr/bin/env python3
"""Fault report: what the robot does under each fault of a two-host deployment, in one table.

    python benchmarks/fault_report.py [--loopback] [--only NAME[,NAME...]] [--log-dir DIR]

The stack runs as it is deployed: the simulated driver and the robot computer's nodes (IK, FK,
climbing) as two processes on the robot host, the operator station's master and teleop as a
third, on two hosts. As root (``ip netns``) the hosts are two network namespaces joined by a
veth pair (tests/netns_rig.py: DDS multicast discovery on that link only); without root, or with
``--loopback``, both run in this machine's namespace on loopback and the link faults are left
out. An agent on each host (tests/netns_agent.py) plays the operator (deadman, climb and driver
services, a sender with an offset clock) and records what the robot does. Faults:

* ``climb_link_<phase>``: the link goes down for 2 s as a climbing step enters each phase
  (release, move, grip of ring_b then ring_a);
* ``climb_kill_operator``, ``climb_kill_driver``: the operator station's or the driver's
  process is killed (SIGKILL) during a climbing motion and restarted 1 s later;
* ``teleop_link``: the link goes down for 2 s while the operator holds the deadman and moves
  the master;
* ``teleop_kill_driver``, ``teleop_kill_robot_nodes``, ``teleop_kill_operator``: each process
  killed in turn during teleoperation and restarted 1 s later (the driver inactive, resuming
  its state file, as the demo restarts it);
* ``clock_ahead``, ``clock_behind``: a sender whose clock is 2 s ahead / behind streams
  targets, then its stream is cut for 2 s (the link goes down; on loopback the sender stops).

Measured from the recorded messages (receipt times and header stamps on the host's one wall
clock): the time from the fault to a safe hold (the last actuators/command reaching the
driver, or the legs coming to rest, whichever is later), the largest leg-length change while
the fault lasted (until the recovery action; a restarted driver's resumed lengths count), the
gripper openings in that time (grippers/state), how the fault was detected (typed status
values) and the recovery action with its outcome.

``run_report`` is also what tests/test_fault_report.py runs, with a few faults.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / 'tests'
sys.path.insert(0, str(TESTS))

import numpy as np  # noqa: E402

from fault_metrics import (climb, first, gripper_openings, in_window, length_change,  # noqa: E402
                           teleop)
from netns_rig import Rig, netns_supported, wait  # noqa: E402

DEADLINE = 90.0
LINK_DOWN = 2.0
STILL = 20e-6
CLIMB_PARAMS = {'climb_node:step_length': 0.05, 'climb_node:speed': 0.025,
                'climb_node:settle_time': 0.4}
PHASES = ('release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a')
ROBOT_RECORD = ('pose', 'actuators/command', 'actuators/state', 'grippers/state', 'target_pose',
                'climb/status', '/diagnostics')
OPERATOR_RECORD = ('teleop/status',)
CLIMB_FAULTS = tuple(f'climb_link_{p}' for p in PHASES) + ('climb_kill_operator', 'climb_kill_driver')
TELEOP_FAULTS = ('teleop_link', 'teleop_kill_driver', 'teleop_kill_robot_nodes', 'teleop_kill_operator',
                 'clock_ahead', 'clock_behind')
FAULTS = CLIMB_FAULTS + TELEOP_FAULTS
LINK_FAULTS = tuple(f for f in FAULTS if 'link' in f) + ('clock_ahead', 'clock_behind')


@dataclasses.dataclass
class Row:
    fault: str
    detected: str = ''
    hold_s: float | None = None
    motion_mm: float | None = None
    held_motion_mm: float | None = None
    openings: int | None = None
    recovery: str = ''
    recovered: bool | None = None
    note: str = ''


class Session:
    """The stack on the rig, with one agent per host."""

    def __init__(self, rig: Rig, state_dir: Path):
        self.rig = rig
        self.state_file = state_dir / 'pole_climber-hardware.json'
        rig.start_driver(state_file=self.state_file, activate=True)
        rig.start_robot_nodes(**CLIMB_PARAMS)
        self.start_operator()
        self.robot = rig.agent('robot', record=ROBOT_RECORD)
        self.operator = rig.agent('operator', record=OPERATOR_RECORD)
        if not wait(lambda: self.robot.records('pose') and self.operator.records('teleop/status')
                    and self.climb_status() is not None, DEADLINE):
            raise RuntimeError('the stack did not come up:\n' + self.logs())
        time.sleep(1.0)

    def start_operator(self):
        return self.rig.start_operator(**{'master_node:trajectory': 'circle'})

    def logs(self) -> str:
        return '\n'.join(f'--- {n}\n{self.rig.log_tail(n, 8)}' for n in self.rig.processes)

    def climb_status(self, since: float = -math.inf):
        rows = self.robot.records('climb/status', since)
        return climb(rows[-1]) if rows else None

    def teleop_status(self, since: float = -math.inf):
        rows = self.operator.records('teleop/status', since)
        return teleop(rows[-1]) if rows else None

    def engaged_and_moving(self, since: float) -> bool:
        s = self.teleop_status(since)
        poses = self.robot.records('pose', since)
        if s is None or not s.engaged or len(poses) < 2:
            return False
        return np.linalg.norm(np.subtract(poses[-1]['p'], poses[0]['p'])) > 1e-3

    def resume(self) -> bool:
        t = time.time()
        if not wait(lambda: self.operator.call('climb/resume', timeout=10.0)['success'], DEADLINE,
                    period=0.3):
            return False
        return wait(lambda: (s := self.climb_status(t)) is not None and s.state.name != 'PAUSED',
                    DEADLINE)

    def finish_step(self, since: float) -> bool:
        """Wait for the climbing step to end idle (resuming after a pause a busy machine caused)."""
        def idle() -> bool:
            c = self.climb_status(since)
            if c is not None and c.state.name == 'PAUSED':
                self.resume()
            return c is not None and c.state.name == 'IDLE'
        return wait(idle, DEADLINE, period=0.3)

    # --- measurements ----------------------------------------------------------------------

    def rest_time(self, start: float, until: float) -> float:
        """Stamp after which the legs stay within STILL of where they end (start if no sample)."""
        window = in_window(self.robot.records('actuators/state'), start, until, by='stamp')
        if not window:
            return start
        final = np.asarray(window[-1]['lengths'])
        t = window[-1]['stamp']
        for r in reversed(window):
            if np.max(np.abs(np.asarray(r['lengths']) - final)) > STILL:
                break
            t = r['stamp']
        return t

    def measure(self, row: Row, t_fault: float, t_end: float, *, driver_down: float | None = None) -> Row:
        """The row's numbers for a fault from ``t_fault`` to the recovery action at ``t_end``;
        ``driver_down``: the driver was dead from ``t_fault`` and restarted (inactive) then, so
        only the commands before its restart could reach it and its legs rest at once."""
        until = t_end if driver_down is None else driver_down
        commands = self.robot.records('actuators/command', t_fault, until)
        last_command = max((c['t'] for c in commands), default=t_fault)
        rest = self.rest_time(t_fault, t_end if driver_down is None else t_fault)
        row.hold_s = max(last_command, rest) - t_fault
        states = self.robot.records('actuators/state')
        row.motion_mm = 1e3 * length_change(states, t_fault, t_end)
        row.held_motion_mm = 1e3 * length_change(states, t_fault + row.hold_s, t_end)
        row.openings = gripper_openings(self.robot.records('grippers/state'), t_fault, t_end)
        return row

    def clutch_delta_mm(self, since: float) -> float:
        """Distance [mm] of the first target after ``since`` from the measured pose then."""
        target = first(self.robot.records('target_pose'), lambda r: True, since)
        if target is None:
            return math.nan
        here = [r for r in self.robot.records('pose') if r['t'] <= target['t']]
        return 1e3 * float(np.linalg.norm(np.subtract(target['p'], here[-1]['p']))) if here else math.nan


# --- climbing faults ------------------------------------------------------------------------

def climb_faults(s: Session, wanted: list[str]) -> list[Row]:
    rows: list[Row] = []
    link = [f.removeprefix('climb_link_') for f in wanted if f.startswith('climb_link_')]
    kills = [f for f in wanted if f.startswith('climb_kill_')]
    for _ in range(6):
        if not link and not kills:
            break
        t_call = time.time()
        replies = []  # refused while a busy machine delays the robot's state: asked again

        def started() -> bool:
            replies.append(s.operator.call('climb/step_up'))
            c = s.climb_status(t_call)
            return replies[-1]['success'] or (c is not None and c.state.name in ('EXECUTING', 'PAUSED'))
        if not wait(started, DEADLINE, period=0.5):
            reply = replies[-1]
            rows.append(Row('climb_step_up', note=f'refused: {reply["message"]}'))
            break
        # from the step's first status on (an idle one may still come in after the request)
        started_at = first(s.robot.records('climb/status'),
                           lambda r: climb(r).state.name in ('EXECUTING', 'PAUSED'), t_call)
        if started_at is None:
            wait(lambda: first(s.robot.records('climb/status'),
                               lambda r: climb(r).state.name in ('EXECUTING', 'PAUSED'), t_call), DEADLINE)
            started_at = first(s.robot.records('climb/status'),
                               lambda r: climb(r).state.name in ('EXECUTING', 'PAUSED'), t_call)
        t_call = started_at['t']
        seen = None
        while True:
            if not wait(lambda: (c := s.climb_status(t_call)) is not None and (
                    c.state.name != 'EXECUTING' or (c.step, c.phase) != seen), DEADLINE):
                raise RuntimeError('the climb stopped reporting:\n' + s.logs())
            c = s.climb_status(t_call)
            if c.state.name in ('IDLE', 'FAILED'):
                if c.state.name == 'FAILED':
                    rows.append(Row('climb', note=f'FAILED: {c.detail}'))
                break
            if c.state.name == 'PAUSED':  # a busy machine delayed the state: resume
                s.resume()
                continue
            seen = (c.step, c.phase)
            if c.phase in link:
                row = climb_link(s, c.phase)
                late = row.note.startswith('late')
                if not late or not c.phase.startswith('release'):
                    link.remove(c.phase)
                    rows.append(row)
                seen = ((d := s.climb_status()).step, d.phase)
            elif kills and c.phase.startswith('move') and c.step >= 1:
                rows.append(climb_kill(s, kills.pop(0)))
                seen = ((d := s.climb_status()).step, d.phase)
    return rows


def climb_link(s: Session, phase: str) -> Row:
    entered = s.robot.records('climb/status')[-1]['t']
    t_down = s.rig.link(False)
    time.sleep(LINK_DOWN)
    t_up = s.rig.link(True)
    # it never resumes by itself: a status well after the link is back still says so
    wait(lambda: s.climb_status(t_up + 1.0) is not None, DEADLINE)
    row = Row(f'link down 2 s in climb {phase}')
    if t_down - entered > 0.25:
        row.note = f'late: the link dropped {t_down - entered:.2f} s into the phase'
    paused = next((climb(r) for r in s.robot.records('climb/status', t_down)
                   if climb(r).state.name == 'PAUSED'), None)
    after = s.climb_status(t_up + 1.0)
    if paused is not None:
        row.detected = f'climb paused in {paused.phase}: {paused.pause_reason.value}'
        still_paused = after is not None and after.state.name == 'PAUSED'
        t_resume = time.time()
        ok = still_paused and s.resume()
        row.recovery = 'operator resumes the climb' + ('' if still_paused else ' (it had not waited!)')
        row.recovered = ok
        return s.measure(row, t_down, t_resume)
    row.detected = f'step completed, climb {after.state.value if after else "?"}'
    row.recovery = 'none: both rings grip, the robot is idle'
    row.recovered = after is not None and after.state.name == 'IDLE'
    return s.measure(row, t_down, time.time())


def climb_kill(s: Session, fault: str) -> Row:
    name = {'climb_kill_operator': 'operator', 'climb_kill_driver': 'driver'}[fault]
    row = Row(f'kill {name} process during climb {s.climb_status().phase}')
    t_kill = time.time()
    s.rig.signal(name, signal.SIGKILL)
    time.sleep(1.0)
    if name == 'operator':
        s.start_operator()
    else:
        s.rig.start_driver(state_file=s.state_file, activate=False)
    t_restart = time.time()
    if not wait(lambda: (c := s.climb_status(t_kill)) is not None and c.state.name == 'PAUSED', DEADLINE):
        row.detected, row.recovered = 'the climb never paused', False
        return s.measure(row, t_kill, time.time())
    c = next(climb(r) for r in s.robot.records('climb/status', t_kill) if climb(r).state.name == 'PAUSED')
    row.detected = f'climb paused: {c.pause_reason.value}'
    if name == 'operator':
        wait(lambda: s.operator.records('teleop/status', t_restart), DEADLINE)
        row.recovery = 'restart the operator station; operator resumes the climb'
        t_action = time.time()
        ok = s.resume()
    else:
        wait(lambda: s.robot.records('actuators/state', t_restart), DEADLINE)
        row.recovery = 'restart the driver (inactive, state file); operator activates it, resumes'
        t_action = time.time()
        ok = s.operator.send({'activate': True})['success'] and s.resume()
    row.recovered = ok and s.finish_step(t_action)
    return s.measure(row, t_kill, t_action, driver_down=t_restart if name == 'driver' else None)


# --- teleoperation faults -------------------------------------------------------------------

def engage(s: Session) -> bool:
    s.operator.send({'deadman': True})
    t = time.time()
    return wait(lambda: s.engaged_and_moving(t), DEADLINE)


def teleop_faults(s: Session, wanted: list[str]) -> list[Row]:
    rows = []
    for fault in wanted:
        if fault.startswith('clock'):
            rows.append(clock_fault(s, +2.0 if fault == 'clock_ahead' else -2.0))
            continue
        if not engage(s):
            rows.append(Row(fault, note='teleop did not engage:\n' + s.logs()))
            continue
        rows.append(TELEOP[fault](s))
    s.operator.send({'deadman': False})
    return rows


def teleop_link(s: Session) -> Row:
    row = Row('link down 2 s during teleop')
    t_down = s.rig.link(False)
    time.sleep(LINK_DOWN)
    t_up = s.rig.link(True)
    codes = {teleop(r).code.name for r in s.operator.records('teleop/status', t_down, t_up)
             if not teleop(r).engaged}
    row.detected = 'teleop ' + ', '.join(sorted(codes))
    ok = wait(lambda: s.engaged_and_moving(t_up), DEADLINE)
    row.recovery = (f'none: the held deadman re-engages as a clutch '
                    f'(first target {s.clutch_delta_mm(t_up):.2f} mm from the pose)')
    row.recovered = ok
    return s.measure(row, t_down, t_up)


def teleop_kill(s: Session, name: str) -> Row:
    row = Row(f'kill {name.replace("_", " ")} process during teleop')
    t_kill = time.time()
    s.rig.signal(name, signal.SIGKILL)
    time.sleep(1.0)
    t_restart = time.time()
    if name == 'driver':
        s.rig.start_driver(state_file=s.state_file, activate=False)
        wait(lambda: (t := s.teleop_status(t_restart)) is not None and t.code.name == 'DRIVER_INACTIVE',
             DEADLINE)
        lost = {teleop(r).code.name for r in s.operator.records('teleop/status', t_kill, t_restart)
                if not teleop(r).engaged}
        row.detected = 'teleop ' + ', '.join(sorted(lost)) + ', then DRIVER_INACTIVE'
        t_action = time.time()
        activated = s.operator.send({'activate': True})['success']
        row.recovery = 'restart the driver (inactive, state file); operator activates it; deadman clutch'
    elif name == 'robot_nodes':
        s.rig.start_robot_nodes(**CLIMB_PARAMS)
        lost = {teleop(r).code.name for r in s.operator.records('teleop/status', t_kill, t_restart)
                if not teleop(r).engaged}
        row.detected = 'teleop ' + ', '.join(sorted(lost))
        t_action, activated = t_restart, True
        row.recovery = 'restart the robot nodes; the held deadman engages as a clutch'
    else:
        s.start_operator()
        row.detected = 'no more targets (teleop is gone)'
        t_action, activated = t_restart, True
        row.recovery = 'restart the operator station; a fresh deadman engages as a clutch'
    ok = activated and wait(lambda: s.engaged_and_moving(t_action), DEADLINE)
    row.recovered = ok
    if ok:
        row.recovery += f' ({s.clutch_delta_mm(t_action):.2f} mm)'
    if name == 'driver':
        early = [r for r in s.operator.records('teleop/status', t_restart, t_action) if teleop(r).engaged]
        if early:  # engaged on the dead driver's last 'active' before the new one reported
            row.note = f'teleop engaged {len(early)}x before the restarted driver reported inactive'
    return s.measure(row, t_kill, t_action, driver_down=t_restart if name == 'driver' else None)


TELEOP = {
    'teleop_link': teleop_link,
    'teleop_kill_driver': lambda s: teleop_kill(s, 'driver'),
    'teleop_kill_robot_nodes': lambda s: teleop_kill(s, 'robot_nodes'),
    'teleop_kill_operator': lambda s: teleop_kill(s, 'operator'),
}


def clock_fault(s: Session, offset: float) -> Row:
    """A sender whose clock is ``offset`` s off streams targets; then its stream is cut."""
    s.operator.send({'deadman': False})
    wait(lambda: (t := s.teleop_status(time.time())) is not None and not t.engaged, DEADLINE)
    row = Row(f'sender clock {offset:+.0f} s, its stream cut 2 s')
    t0 = time.time()
    s.operator.send({'sender': {'offset': offset, 'amplitude': 0.004, 'period': 2.0}})
    followed = wait(lambda: len(s.robot.records('actuators/command', t0 + 1.0)) > 20, DEADLINE)
    if s.rig.can_cut_link:
        t_cut = s.rig.link(False)
        time.sleep(LINK_DOWN)
        t_back = s.rig.link(True)
    else:
        s.operator.send({'sender': None})
        t_cut = time.time()
        time.sleep(LINK_DOWN)
        s.operator.send({'sender': {'offset': offset, 'amplitude': 0.004, 'period': 2.0}})
        t_back = time.time()
    resumed = wait(lambda: len(s.robot.records('actuators/command', t_back + 0.3)) > 10, DEADLINE)
    s.operator.send({'sender': None})
    row.detected = ('followed the offset clock' if followed else 'never followed the stream')
    row.recovery = 'none: the stream resumes (its clock offset is learned)'
    row.recovered = followed and resumed
    return s.measure(row, t_cut, t_back)


# --- the report -----------------------------------------------------------------------------

def run_report(*, only: list[str] | None = None, loopback: bool = False, domain_id: int | None = None,
               log_dir: str | Path | None = None) -> list[Row]:
    """Run the faults (``only``: a subset of FAULTS) and return their rows."""
    wanted = list(FAULTS if not only else only)
    unknown = set(wanted) - set(FAULTS)
    if unknown:
        raise ValueError(f'unknown faults {sorted(unknown)}; known: {", ".join(FAULTS)}')
    isolated = not loopback and netns_supported()[0]
    rows: list[Row] = []
    if not isolated:
        for fault in [f for f in wanted if f in LINK_FAULTS and not f.startswith('clock')]:
            rows.append(Row(fault, note='not run: cutting a link needs root (network namespaces)'))
        wanted = [f for f in wanted if f not in LINK_FAULTS or f.startswith('clock')]
    domain = domain_id if domain_id is not None else 150 + os.getpid() % 50
    state_dir = Path(tempfile.mkdtemp(prefix='rrps-faults-'))
    try:
        with Rig(domain, discovery='subnet' if isolated else 'loopback', log_dir=log_dir) as rig:
            s = Session(rig, state_dir)
            climbing = [f for f in wanted if f in CLIMB_FAULTS]
            if climbing:
                rows += climb_faults(s, climbing)
            teleoperating = [f for f in wanted if f in TELEOP_FAULTS]
            if teleoperating:
                rows += teleop_faults(s, teleoperating)
    finally:
        shutil.rmtree(state_dir, ignore_errors=True)
    return rows


def table(rows: list[Row]) -> str:
    head = ('fault', 'detected as', 'safe hold after', 'motion during fault', 'gripper openings',
            'recovery action')

    def cells(r: Row) -> tuple:
        if r.note and r.hold_s is None:
            return (r.fault, r.note, '', '', '', '')
        return (r.fault + (f' ({r.note})' if r.note else ''), r.detected,
                '' if r.hold_s is None else f'{r.hold_s:.2f} s',
                '' if r.motion_mm is None or math.isnan(r.motion_mm) else
                f'{r.motion_mm:.2f} mm ({r.held_motion_mm:.3f} mm held)',
                '' if r.openings is None else str(r.openings),
                r.recovery + ('' if r.recovered is None else ': ok' if r.recovered else ': FAILED'))
    body = [cells(r) for r in rows]
    widths = [max(len(str(x[i])) for x in [head] + body) for i in range(len(head))]
    line = '|' + '|'.join('-' * (w + 2) for w in widths) + '|'
    fmt = lambda cols: '| ' + ' | '.join(str(c).ljust(w) for c, w in zip(cols, widths)) + ' |'
    return '\n'.join([fmt(head), line] + [fmt(b) for b in body])


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
    print('\nsafe hold after: from the fault until the last actuators/command reached the driver '
          'and the legs came to rest (20 um); motion: largest leg-length change from the fault '
          'until the recovery action (a restarted driver\'s resumed lengths count), and in '
          'brackets from the safe hold on.')
    return 0 if all(r.recovered is not False for r in rows) else 1


if __name__ == '__main__':
    sys.exit(main())
