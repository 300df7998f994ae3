"""The operator link as it is in the field: the two-host split of docs/deployment.md on a rig whose link is
shaped (rrps_testing.link_shaping), teleop engaged and a climbing step, judged from the records.

The operator station's subscription pattern is ``'direct'`` (teleop and viewer read the robot's own topics
across the link) or ``'link'`` (they read ``link_relay_node``'s link topics, ``robot_topics:=link``).
:meth:`FieldSession.run` drives one :class:`Profile` (bandwidth, loss, outages) and returns a :class:`Result`.
Each agent records only its own host's topics, so that the agents add little to the link.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from rrps_interfaces.climb import ClimbState
from rrps_interfaces.teleop import DISENGAGED_CODES, TeleopCode, ViewerStatus
from rrps_testing.fault_metrics import climb, first, gripper_openings, in_window, teleop
from rrps_testing.link_shaping import LinkShaping, veth_bytes
from rrps_testing.netns import wait
from rrps_testing.netns_rig import Rig

__all__ = ['PATTERNS', 'Profile', 'PROFILES', 'Result', 'FieldSession']

PATTERNS = ('direct', 'link')
DEADLINE = 90.0
ROBOT_RECORD = ('pose', 'actuators/command', 'actuators/state', 'grippers/state', 'climb/status',
                '/diagnostics')
OPERATOR_RECORD = ('teleop/status', 'teleop/enable')
CLIMB_PARAMS = {'climb_node:step_length': 0.03, 'climb_node:speed': 0.03, 'climb_node:settle_time': 0.2}
MAX_LINEAR_SPEED = 0.05    # m/s, teleop's slave speed limit (default)
COMMAND_TIMEOUT = 0.1      # s, the IK node's command timeout (default)
ENGAGE_GRACE = 1.5         # s after a link returns before teleop must be engaged again
ROBOT_STALL = 0.1          # s: a longer gap in the robot's own pose stream is a stall of its processes
#: s: the discovered graph is settled once both agents saw it unchanged this long
GRAPH_SETTLE = 3.0
_GRAPH = ('nodes', 'topics', 'services', 'endpoints')
#: teleop codes of an engaged mapping
ENGAGED = frozenset(TeleopCode) - DISENGAGED_CODES
#: disengagements whose cause is on the operator station itself: teleop runs there beside the master and
#: the deadman, so neither stream crosses the link; with the deadman held they are stalls of a busy machine
OPERATOR_STALLS = frozenset({TeleopCode.MASTER_STALE, TeleopCode.DEADMAN_RELEASED})


@dataclasses.dataclass(frozen=True)
class Profile:
    """A field link: bandwidth [bit/s] each way (None: the veth's), random loss share, and an
    outage of ``outage[1]`` s every ``outage[0]`` s."""

    name: str
    robot_to_operator: float | None = None
    operator_to_robot: float | None = None
    loss: float = 0.0
    outage: tuple[float, float] | None = None


PROFILES = {
    'clean': Profile('clean'),
    '2M': Profile('2 Mbit/s, 500 kbit/s back', 2e6, 500e3),
    '500k_loss': Profile('500 kbit/s each way, 5 % loss', 500e3, 500e3, 0.05),
    'outages': Profile('2 Mbit/s, 500 kbit/s back, 1 s outage every 10 s', 2e6, 500e3, outage=(10.0, 1.0)),
}


@dataclasses.dataclass
class Result:
    """What one profile did (see :meth:`FieldSession.run`); rates in bit/s, ages in ms, motion in mm."""

    profile: str
    pattern: str
    robot_to_operator: float = math.nan
    operator_to_robot: float = math.nan
    motion_mm: float = math.nan
    age_p50: float | None = None
    age_p99: float | None = None
    engaged_share: float = 0.0
    codes: list[str] = dataclasses.field(default_factory=list)
    spurious: int = 0
    stalls: int = 0
    #: the longest gap [s] between the robot's own pose samples on the robot host (by stamp):
    #: a stall of the robot's processes (a busy machine), not of the link
    robot_gap: float = math.nan
    viewer_rate: float | None = None
    clutch_mm: list[tuple[float, float]] = dataclasses.field(default_factory=list)
    outage_holds: list[float] = dataclasses.field(default_factory=list)
    outage_gripper_switches: int = 0
    climb: str = ''

    @property
    def follows(self) -> bool:
        return self.motion_mm > 5.0 and self.engaged_share > 0.5

    @property
    def no_jump(self) -> bool:
        return all(jump <= allowed for jump, allowed in self.clutch_mm)

    def met(self, *, age_limit: float = 100.0, viewer_limit: float = 10.0) -> bool:
        """The targets: teleop follows without a spurious disengagement (one the operator
        station's own stalls caused, :data:`OPERATOR_STALLS`, is counted in ``stalls``), slave-state age
        p99 below ``age_limit`` ms, the viewer at ``viewer_limit`` Hz or more, never a jump,
        never a gripper switch on a lost link, and the climbing step ends idle."""
        return (self.follows and self.spurious == 0 and self.age_p99 is not None and self.age_p99 < age_limit
                and self.viewer_rate is not None and self.viewer_rate >= viewer_limit and self.no_jump
                and self.outage_gripper_switches == 0 and self.climb.startswith('IDLE'))


def _outage(link: LinkShaping, length: float) -> tuple[float, float]:
    """Take the link down for ``length`` s; (down, up): both times within the outage (the link
    comes back during ``link.outage(False)``, and a command sent then may cross it at once)."""
    link.outage(True)
    down = time.time()
    time.sleep(length)
    up = time.time()
    link.outage(False)
    return down, up


class FieldSession:
    """The two-host split of docs/deployment.md on ``rig`` in ``pattern`` (module docstring).

    ``driver_rate`` [Hz]: the driver's (500 in the demo); ``master_rate`` [Hz]: the master's;
    ``command_rate`` [Hz]: teleop's commands on a timer (None: one per master sample, teleop's
    default); ``render_rate``: the viewer's; ``relay``: link_relay_node's parameters."""

    def __init__(self, rig: Rig, pattern: str, *, driver_rate: float = 500.0, master_rate: float = 200.0,
                 command_rate: float | None = None, render_rate: float = 10.0, relay: dict | None = None):
        if pattern not in PATTERNS:
            raise ValueError(f'pattern must be one of {PATTERNS}, got {pattern!r}')
        self.rig, self.pattern = rig, pattern
        link = pattern == 'link'
        rig.start_driver(rate=driver_rate)
        nodes = ['ik_node', 'fk_node', 'climb_node'] + (['link_relay_node'] if link else [])
        relay_params = {f'link_relay_node:{k}': v for k, v in (relay or {}).items()}
        rig.python('robot', 'robot_nodes', ['-m', 'rrps_bringup.compose', *nodes, *rig.ros_args(
            {'robot': 'pole_climber', **CLIMB_PARAMS, **relay_params})])
        operator = {'master_node:trajectory': 'circle', 'master_node:rate': master_rate,
                    'teleop_node:robot_topics': pattern, 'viewer_node:robot_topics': pattern,
                    'viewer_node:robot': 'pole_climber', 'viewer_node:token': 'field-link-token',
                    'viewer_node:render_rate': render_rate, 'viewer_node:workspace_resolution': 0.0}
        if command_rate is not None:  # commands on a timer, not once per master sample
            operator.update({'teleop_node:control': 'timer', 'teleop_node:control_rate': command_rate})
        rig.python('operator', 'operator', ['-m', 'rrps_bringup.compose', 'master_node', 'teleop_node',
                                            'viewer_node', *rig.ros_args(operator)])
        self.robot = rig.agent('robot', record=ROBOT_RECORD)
        self.operator = rig.agent('operator', record=OPERATOR_RECORD)
        if not wait(lambda: self.robot.records('pose') and self.operator.records('teleop/status')
                    and self.robot.records('climb/status') and self.viewer_statuses(), DEADLINE):
            raise RuntimeError('the stack did not come up:\n' + self.logs())
        self.graph = self._settle()

    def _settle(self) -> dict:
        """Wait until DDS discovery has settled: both agents' graphs unchanged for GRAPH_SETTLE s.
        The stack's data flows before every endpoint is discovered across the link; a profile
        started then would judge the start-up's discovery (its SEDP exchange, resent on a lossy
        link) rather than the link's steady use. The graph the operator agent saw."""
        def graph() -> tuple:
            replies = [agent.send({'graph': True}) for agent in (self.robot, self.operator)]
            return tuple(tuple((k, r[k]) for k in _GRAPH) for r in replies)
        last, since = graph(), time.monotonic()

        def settled() -> bool:
            nonlocal last, since
            now = graph()
            if now != last:
                last, since = now, time.monotonic()
            return time.monotonic() - since >= GRAPH_SETTLE
        if not wait(settled, DEADLINE, period=0.5):
            raise RuntimeError(f'discovery did not settle in {DEADLINE} s: {last}')
        return dict(last[1])

    def logs(self) -> str:
        return '\n'.join(f'--- {n}\n{self.rig.log_tail(n, 12)}' for n in self.rig.processes)

    def shaping(self) -> LinkShaping:
        return LinkShaping(self.rig.robot, 'veth0', self.rig.operator, 'veth1')

    def viewer_statuses(self, start: float = -math.inf, end: float = math.inf) -> list[ViewerStatus]:
        return [ViewerStatus.from_values(r['values']) for r in self.robot.records('/diagnostics', start, end)
                if r['node'] == 'viewer_node']

    def bytes(self) -> tuple[float, int, int]:
        """(time, robot -> operator bytes, operator -> robot bytes) of the veth pair."""
        tx, rx = veth_bytes(self.rig.robot, 'veth0')
        return time.time(), tx, rx

    def idle(self) -> None:
        """Deadman released, teleop disengaged, no climb running."""
        self.operator.send({'deadman': False})
        t = time.time()
        wait(lambda: (r := self.operator.records('teleop/status', t + 0.3)) and not teleop(r[-1]).engaged, 10.0)

        def climb_idle() -> bool:
            rows = self.robot.records('climb/status')
            state = climb(rows[-1]).state if rows else None
            if state is ClimbState.PAUSED:
                self.operator.call('climb/resume', timeout=10.0)
            return state in (ClimbState.IDLE, ClimbState.FAILED)
        wait(climb_idle, DEADLINE, period=0.3)

    # --- one profile ---------------------------------------------------------------------

    def run(self, profile: Profile, *, teleop_time: float = 12.0, climb_step: bool = True) -> Result:
        """Teleop engaged for ``teleop_time`` s, then (``climb_step``) one climbing step, on the
        link of ``profile``; the link is clean again afterwards, whatever happens."""
        result = Result(profile.name, self.pattern)
        self.idle()
        with self.shaping() as link:
            link.limit(robot_to_operator=profile.robot_to_operator, operator_to_robot=profile.operator_to_robot)
            link.loss(profile.loss)
            time.sleep(1.0)  # the queues settle
            pressed = time.time()
            self.operator.send({'deadman': True})
            wait(lambda: self._engaged(time.time() - 0.2), 10.0)
            t0, tx0, rx0 = self.bytes()
            outages = self._teleop(link, profile, teleop_time)
            t1, tx1, rx1 = self.bytes()
            self.operator.send({'deadman': False})
            result.robot_to_operator = 8.0 * (tx1 - tx0) / (t1 - t0)
            result.operator_to_robot = 8.0 * (rx1 - rx0) / (t1 - t0)
            self._judge_teleop(result, t0, t1, outages)
            result.clutch_mm.insert(0, self._clutch(pressed))
            if climb_step:
                result.climb, switched = self._climb(link, profile, outages)
                result.outage_gripper_switches += switched
        return result

    def _engaged(self, since: float) -> bool:
        rows = self.operator.records('teleop/status', since)
        return bool(rows) and teleop(rows[-1]).engaged

    def _teleop(self, link: LinkShaping, profile: Profile, duration: float) -> list[tuple[float, float]]:
        """Hold the deadman for ``duration`` s; the outages of the profile as (down, up) times."""
        outages = []
        end = time.time() + duration
        while time.time() < end:
            if profile.outage is None:
                time.sleep(max(end - time.time(), 0.0))
                break
            period, length = profile.outage
            time.sleep(min(period - length, max(end - time.time(), 0.0)))
            if time.time() + length > end:
                break
            outages.append(_outage(link, length))
        return outages

    def _judge_teleop(self, result: Result, t0: float, t1: float, outages: list[tuple[float, float]]) -> None:
        """Teleop's codes, ages and disengagements in [t0, t1]. A disengagement while the robot's
        own pose stream stalled on the robot host (a gap over ROBOT_STALL, and 0.5 s after it)
        or for the operator station's own streams (:data:`OPERATOR_STALLS`, the deadman held
        throughout) is a stall of a busy machine, not of the link: counted in ``stalls``, its ages left out."""
        statuses = self.operator.records('teleop/status', t0, t1)
        typed = [teleop(r) for r in statuses]
        result.codes = sorted({s.code.name for s in typed})
        result.engaged_share = sum(s.engaged for s in typed) / max(len(typed), 1)
        poses = in_window(self.robot.records('pose'), t0 - 1.0, t1, by='stamp')
        stamps = np.array(sorted(r['stamp'] for r in poses))
        gaps = [(a, b + 0.5) for a, b in zip(stamps[:-1], stamps[1:]) if b - a > ROBOT_STALL]

        def stalled(t: float) -> bool:
            return any(a <= t <= b for a, b in gaps)

        def nominal(t: float) -> bool:  # the link was up long enough to be engaged again
            return not any(down <= t <= up + ENGAGE_GRACE for down, up in outages)
        ages = [s.slave_age_ms for r, s in zip(statuses, typed)
                if s.engaged and s.slave_age_ms is not None and not stalled(r['t'])]
        if ages:
            result.age_p50, result.age_p99 = (float(np.percentile(ages, q)) for q in (50, 99))
        previous = True
        for r, s in zip(statuses, typed):
            if nominal(r['t']) and previous and not s.engaged:
                if s.code in OPERATOR_STALLS or stalled(r['t']):
                    result.stalls += 1
                else:
                    result.spurious += 1
            previous = s.engaged or not nominal(r['t'])
        window = [r for r in poses if t0 <= r['stamp'] <= t1]
        if len(window) > 1:
            p = np.array([r['p'] for r in window])
            result.motion_mm = 1e3 * float(np.max(np.ptp(p, axis=0)))
            result.robot_gap = float(np.max(np.diff(stamps[stamps >= t0])))
        rates = [v.pose_rate for v in self.viewer_statuses(t0 + 1.0, t1)]
        result.viewer_rate = float(np.median(rates)) if rates else None
        for down, up in outages:
            commands = self.robot.records('actuators/command', down, up)
            last = max((c['stamp'] for c in commands if 'stamp' in c), default=down)
            result.outage_holds.append(last - down)
            result.outage_gripper_switches += gripper_openings(self.robot.records('grippers/state'), down, up)
            result.clutch_mm.append(self._clutch(up))

    def _clutch(self, since: float) -> tuple[float, float]:
        """The first actuators/command after ``since`` (the deadman pressed, or the link back)
        against the legs then, and what the slave's speed limit allows since teleop engaged
        (+ 0.5 mm) [mm]. Only this engagement's commands count: one streamed before it (a
        previous engagement's, its stop) is a planned motion the driver's jerk-limited
        setpoints follow with a lag, not a jump."""
        command = first(self.robot.records('actuators/command'), lambda r: True, since)
        engaged = first(self.operator.records('teleop/status'), lambda r: teleop(r).engaged, since)
        legs = [r for r in self.robot.records('actuators/state') if command and r['t'] <= command['t']]
        if command is None or engaged is None or not legs:
            return (math.nan, math.nan)
        jump = 1e3 * float(np.max(np.abs(np.subtract(command['lengths'], legs[-1]['lengths']))))
        return jump, 1e3 * MAX_LINEAR_SPEED * max(command['stamp'] - engaged['t'], 0.0) + 0.5

    def _climb(self, link: LinkShaping, profile: Profile, outages: list) -> tuple[str, int]:
        """One climbing step on the link (outages as the profile says, resumed by the operator
        as the link-loss rules want): its end state and pauses, and the gripper openings during
        its outages (from 0.3 s after one began: a release decided before it may still complete)."""
        self.idle()
        t_call = time.time()
        if not wait(lambda: self.operator.call('climb/step_up', timeout=10.0)['success'], 30.0, period=0.5):
            return 'REFUSED', 0
        before = len(outages)
        pauses: list[str] = []

        def started() -> bool:  # the step stays IDLE while its preview runs
            rows = self.robot.records('climb/status', t_call)
            last = climb(rows[-1]) if rows else None
            return last is not None and (last.state is not ClimbState.IDLE
                                         or (last.refusal is not None and not last.previewing))
        if not wait(started, DEADLINE, period=0.2):
            return 'NOT STARTED', 0
        first_status = climb(self.robot.records('climb/status', t_call)[-1])
        if first_status.state is ClimbState.IDLE:
            return f'REFUSED ({first_status.refusal.name})', 0
        next_outage = time.time() + (2.0 if profile.outage else math.inf)  # during the first motion
        deadline = time.time() + DEADLINE
        while time.time() < deadline:
            rows = self.robot.records('climb/status', t_call)
            state = climb(rows[-1]).state if rows else None
            if state in (ClimbState.IDLE, ClimbState.FAILED):
                break
            if state is ClimbState.PAUSED:
                reason = climb(rows[-1]).pause_reason
                pauses.append(reason.name if reason else '?')
                self.operator.call('climb/resume', timeout=10.0)
            if time.time() >= next_outage:
                outages.append(_outage(link, profile.outage[1]))
                next_outage = time.time() + profile.outage[0] - profile.outage[1]
            time.sleep(0.2)
        rows = self.robot.records('climb/status', t_call)
        grippers = self.robot.records('grippers/state')
        switched = sum(gripper_openings(grippers, down + 0.3, up) for down, up in outages[before:])
        end = climb(rows[-1]).state.name if rows else 'NO STATUS'
        paused = f'{len(pauses)} pauses resumed ({", ".join(sorted(set(pauses)))})' if pauses else 'no pause'
        return f'{end}, {paused}', switched
