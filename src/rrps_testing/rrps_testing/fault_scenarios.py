"""The faults of the fault report, each run on a :class:`rrps_testing.fault_session.Session`: a
lost link or a killed process during a climbing step, and a killed demo (the same and clock
faults during teleoperation: :mod:`rrps_testing.teleop_faults`)."""

from __future__ import annotations

import os
import shutil
import signal
import sys
import tempfile
import time

from rrps_runtime.supervision import child_pids, process_alive
from rrps_testing.fault_metrics import climb, first
from rrps_testing.fault_session import DEADLINE, LINK_DOWN, Row, Session
from rrps_testing.netns import wait

# --- climbing faults ------------------------------------------------------------------------

def step_up(s: Session) -> float | None:
    """Start a climbing step; the receipt time of its first running status (None: refused)."""
    t_call = time.time()
    replies = []

    def started() -> bool:  # refused while a busy machine delays the robot's state: again
        replies.append(s.operator.call('climb/step_up'))
        c = s.climb_status(t_call)
        return replies[-1]['success'] or (c is not None and c.state.name in ('EXECUTING', 'PAUSED'))
    if not wait(started, DEADLINE, period=0.5):
        return None
    running = lambda r: climb(r).state.name in ('EXECUTING', 'PAUSED')  # noqa: E731
    wait(lambda: first(s.robot.records('climb/status'), running, t_call), DEADLINE)
    found = first(s.robot.records('climb/status'), running, t_call)
    return None if found is None else found['t']


def climb_faults(s: Session, wanted: list[str]) -> list[Row]:
    rows: list[Row] = []
    link = [f.removeprefix('climb_link_') for f in wanted if f.startswith('climb_link_')]
    kills = [f for f in wanted if f.startswith('climb_kill_')]
    # the robot nodes' restart loses the climb's plan: last
    kills.sort(key=lambda f: f == 'climb_kill_robot_nodes')
    for _ in range(8):
        if not link and not kills:
            break
        t_call = step_up(s)
        if t_call is None:
            print(f'climb step_up refused:\n{s.logs()}', file=sys.stderr)
            rows.append(Row('climb step_up', note='refused (logs on stderr)'))
            break
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
                row = climb_link(s, c.phase, first(s.robot.records('climb/status'), lambda r: (
                    climb(r).step, climb(r).phase) == seen, t_call)['t'])
                late = row.note.startswith('late')
                if not late or not c.phase.startswith('release'):
                    link.remove(c.phase)
                    rows.append(row)
            elif kills and c.phase.startswith('move') and not (
                    kills[0] == 'climb_kill_robot_nodes' and link):
                row = climb_kill(s, kills.pop(0), c.phase)
                rows.append(row)
                if row.fault.startswith('kill robot nodes'):
                    break  # that step is over (the restarted climb node planned a new one)
            else:
                continue
            d = s.climb_status()
            seen = (d.step, d.phase)
    return rows


def climb_link(s: Session, phase: str, entered: float) -> Row:
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
        row.detected = f'climb PAUSED in {paused.phase}: {paused.pause_reason.value}'
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


def climb_kill(s: Session, fault: str, phase: str) -> Row:
    name = fault.removeprefix('climb_kill_')
    row = Row(f'kill {name.replace("_", " ")} process during climb {phase}')
    t_kill = time.time()
    s.rig.signal(name, signal.SIGKILL)
    time.sleep(1.0)
    t_restart = time.time()
    {'operator': s.start_operator, 'driver': s.start_driver, 'robot_nodes': s.start_robot_nodes}[name]()
    if name == 'robot_nodes':
        return climb_restarted_nodes(s, row, t_kill, t_restart)
    if not wait(lambda: (c := s.climb_status(t_kill)) is not None and c.state.name == 'PAUSED', DEADLINE):
        row.detected, row.recovered = 'the climb never paused', False
        return s.measure(row, t_kill, time.time())
    c = next(climb(r) for r in s.robot.records('climb/status', t_kill) if climb(r).state.name == 'PAUSED')
    row.detected = f'climb PAUSED in {c.phase}: {c.pause_reason.value}'
    if name == 'operator':
        wait(lambda: s.operator.records('teleop/status', t_restart), DEADLINE)
        row.recovery = 'restart the operator station; operator resumes the climb'
        t_action = time.time()
        ok = s.resume()
    else:
        wait(lambda: s.robot.records('actuators/state', t_restart), DEADLINE)
        row.note = f'resumed {s.resumed_offset_mm(t_kill, t_restart):.2f} mm from its last state'
        row.recovery = 'restart the driver (inactive, state file); operator activates it, resumes'
        t_action = time.time()
        ok = activate(s) and s.resume()
    row.recovered = ok and s.finish_step(t_action)
    return s.measure(row, t_kill, t_action, commands_until=t_restart if name == 'driver' else None)


def climb_restarted_nodes(s: Session, row: Row, t_kill: float, t_restart: float) -> Row:
    """IK, FK and the climb node died with the step's plan; the restarted climb node is idle."""
    wait(lambda: (c := s.climb_status(t_restart)) is not None and c.state.name == 'IDLE', DEADLINE)
    closed = s.robot.records('grippers/state')[-1]['closed']
    opened = ', '.join(r for r, c in closed.items() if not c) or 'no ring'
    row.detected = ('commands stopped (robot nodes gone), driver holds; restarted climb node '
                    f'IDLE, {opened} open')
    row.recovery = 'restart the robot nodes; operator starts a new step (ring_b re-grips first)'
    t_action = time.time()
    s.measure(row, t_kill, t_action)
    started = step_up(s)
    row.recovered = started is not None and s.finish_step(started)
    if not row.recovered:
        row.note = f'climb {s.climb_status().state.value}: {s.climb_status().detail}'
    return row


def activate(s: Session) -> bool:
    """The operator activates the restarted driver (asked again until its service answers)."""
    return wait(lambda: s.operator.send({'activate': True})['success'], DEADLINE, period=0.5)


# --- supervision ------------------------------------------------------------------------------



def demo_kill(domain_id: int) -> Row:
    """The demo killed: the time until every process it started is gone."""
    import socket
    import subprocess
    row = Row('kill the demo (supervisor of driver, robot nodes, observers)')
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        port = sock.getsockname()[1]
    env = {**os.environ, 'ROS_DOMAIN_ID': str(domain_id), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'PYTHONUNBUFFERED': '1'}
    env.pop('ROS_DISCOVERY_SERVER', None)
    cwd = tempfile.mkdtemp(prefix='rrps-faults-demo-')  # its flight recordings
    proc = subprocess.Popen([sys.executable, '-m', 'rrps_bringup.demo', '--port', str(port),
                             '--token', 'fault-report-token'], env=env, cwd=cwd, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line or 'is live' in line:  # the banner: the robot processes are up
                break
        children = child_pids(proc.pid)
        t_kill = time.time()
        proc.kill()
        proc.wait()
        gone = wait(lambda: not any(process_alive(c) for c in children), 15.0, period=0.01)
        row.hold_s = time.time() - t_kill
        row.detected = f'its {len(children)} children see the parent die (parent-death signal)'
        row.recovery = 'restart the demo'
        row.recovered = gone and len(children) == 3
        row.note = 'time to hold: until every child process is gone'
    finally:
        if proc.poll() is None:
            proc.kill()
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        shutil.rmtree(cwd, ignore_errors=True)
    return row


