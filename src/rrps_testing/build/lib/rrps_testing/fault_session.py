"""The fault report's session: the stack on a two-host rig with an agent per host, and a row of
the report (what the robot did under one fault). The scenarios are :mod:`rrps_testing.fault_scenarios`."""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from rrps_testing.fault_metrics import climb, first, gripper_openings, length_change, teleop
from rrps_testing.netns import wait
from rrps_testing.netns_rig import Rig

DEADLINE = 90.0
LINK_DOWN = 2.0
SETTLE = 0.5               # s: the actuators' lag (20 ms time constant) has settled
MAX_LINEAR_SPEED = 0.05    # m/s, teleop's slave speed limit (default)
CLIMB_PARAMS = {'climb_node:step_length': 0.05, 'climb_node:speed': 0.025,
                'climb_node:settle_time': 0.4}
PHASES = ('release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a')
ROBOT_RECORD = ('pose', 'actuators/command', 'actuators/state', 'grippers/state', 'target_pose',
                'climb/status', '/diagnostics')
OPERATOR_RECORD = ('teleop/status',)
CLIMB_FAULTS = tuple(f'climb_link_{p}' for p in PHASES) + (
    'climb_kill_operator', 'climb_kill_driver', 'climb_kill_robot_nodes')
TELEOP_FAULTS = ('teleop_link', 'teleop_deadman_silent', 'teleop_rtt_250', 'teleop_rtt_400',
                 'teleop_kill_driver', 'teleop_kill_robot_nodes', 'teleop_kill_operator',
                 'clock_ahead', 'clock_behind', 'clock_late')
FAULTS = CLIMB_FAULTS + TELEOP_FAULTS + ('demo_kill',)
LINK_FAULTS = tuple(f for f in FAULTS if 'link' in f)
SENDER = {'offset': 2.0, 'amplitude': 0.004, 'period': 2.0}


@dataclasses.dataclass
class Row:
    """One row of the fault report: the fault, how it was detected, the time to a safe hold, the motion
    (and the motion once held) [mm], the gripper openings and the recovery with its outcome."""
    fault: str
    detected: str = ''
    hold_s: float | None = None
    motion_mm: float | None = None
    held_motion_mm: float | None = None
    openings: int | None = None
    recovery: str = ''
    recovered: bool | None = None
    note: str = ''
    #: re-engaging: the first target's distance from the pose and what the speed limit allows [mm]
    clutch_mm: tuple[float, float] | None = None


class Session:
    """The stack on the rig, with one agent per host."""

    def __init__(self, rig: Rig, state_dir: Path):
        self.rig = rig
        self.state_file = state_dir / 'pole_climber-hardware.json'
        rig.start_driver(state_file=self.state_file, activate=True)
        self.start_robot_nodes()
        self.start_operator()
        self.robot = rig.agent('robot', record=ROBOT_RECORD)
        self.operator = rig.agent('operator', record=OPERATOR_RECORD)
        if not wait(lambda: self.robot.records('pose') and self.operator.records('teleop/status')
                    and self.climb_status() is not None, DEADLINE):
            raise RuntimeError('the stack did not come up:\n' + self.logs())
        time.sleep(1.0)

    def start_operator(self):
        return self.rig.start_operator(**{'master_node:trajectory': 'circle'})

    def start_robot_nodes(self):
        return self.rig.start_robot_nodes(**CLIMB_PARAMS)

    def start_driver(self):
        """The driver as the demo restarts it: inactive, resuming its state file."""
        return self.rig.start_driver(state_file=self.state_file, activate=False)

    def logs(self) -> str:
        return '\n'.join(f'--- {n}\n{self.rig.log_tail(n, 8)}' for n in self.rig.processes)

    def climb_status(self, since: float = -math.inf):
        rows = self.robot.records('climb/status', since)
        return climb(rows[-1]) if rows else None

    def teleop_status(self, since: float = -math.inf):
        rows = self.operator.records('teleop/status', since)
        return teleop(rows[-1]) if rows else None

    def teleop_codes(self, start: float, end: float, engaged: bool = False) -> list[str]:
        """The teleop codes seen in [start, end] (receipts) while (not) engaged, in order."""
        codes: list[str] = []
        for r in self.operator.records('teleop/status', start, end):
            s = teleop(r)
            if s.engaged == engaged and s.code.name not in codes:
                codes.append(s.code.name)
        return codes

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
        return wait(lambda: first(self.robot.records('climb/status'),
                                  lambda r: climb(r).state.name != 'PAUSED', t) is not None, DEADLINE)

    def finish_step(self, since: float) -> bool:
        """Wait for the climbing step to end idle (resuming after a pause a busy machine caused)."""
        def idle() -> bool:
            c = self.climb_status(since)
            if c is not None and c.state.name == 'PAUSED':
                self.resume()
            return c is not None and c.state.name in ('IDLE', 'FAILED')
        return wait(idle, DEADLINE, period=0.3) and self.climb_status().state.name == 'IDLE'

    # --- measurements ----------------------------------------------------------------------

    def measure(self, row: Row, t_fault: float, t_end: float, *, commands_until: float | None = None) -> Row:
        """The row's numbers for a fault from ``t_fault`` to the recovery action at ``t_end``:
        the hold is the last actuators/command published before ``commands_until`` (default
        ``t_end``)."""
        commands = self.robot.records('actuators/command', t_fault, commands_until or t_end)
        last = max((c['t'] for c in commands), default=t_fault)
        row.hold_s = last - t_fault
        states = self.robot.records('actuators/state')
        row.motion_mm = 1e3 * length_change(states, t_fault, t_end)
        row.held_motion_mm = (1e3 * length_change(states, last + SETTLE, t_end)
                              if t_end > last + SETTLE + 0.1 else math.nan)
        row.openings = gripper_openings(self.robot.records('grippers/state'), t_fault, t_end)
        return row

    def clutch(self, since: float, row: Row) -> str:
        """How the first command after ``since`` relates to the robot's legs: a clutch starts at
        the robot's pose, so its leg lengths differ from the measured ones by at most what the
        slave's speed limit allows since teleop engaged (+ 0.5 mm); also kept in
        ``row.clutch_mm``. The IK's commands, not the teleop's targets: the robot host's agent
        has long discovered the IK, while a restarted teleop's first targets may reach the IK
        before the agent matches their new publisher."""
        if not wait(lambda: first(self.robot.records('actuators/command'), lambda r: True, since), 10.0):
            return 'no command recorded'
        command = first(self.robot.records('actuators/command'), lambda r: True, since)
        engaged = first(self.operator.records('teleop/status'), lambda r: teleop(r).engaged, since)
        legs = [r for r in self.robot.records('actuators/state') if r['t'] <= command['t']]
        if not legs or engaged is None:
            return 'no leg state or engaged status recorded'
        jump = 1e3 * float(np.max(np.abs(np.subtract(command['lengths'], legs[-1]['lengths']))))
        allowed = 1e3 * MAX_LINEAR_SPEED * max(command['stamp'] - engaged['t'], 0.0) + 0.5
        row.clutch_mm = (jump, allowed)
        return f'clutch: first command {jump:.2f} mm from the legs (allowed {allowed:.2f} mm)'

    def resumed_offset_mm(self, t_kill: float, t_restart: float) -> float:
        """How far [mm] the restarted driver's first state is from the dead one's last."""
        states = self.robot.records('actuators/state')
        before = [r for r in states if r['t'] <= t_kill]
        after = first(states, lambda r: True, t_restart)
        if not before or after is None:
            return math.nan
        return 1e3 * float(np.max(np.abs(np.subtract(after['lengths'], before[-1]['lengths']))))


