"""The stack on two hosts: a robot (driver, IK, FK, climbing) and an operator station (master,
teleop, viewer, a browser) in two network namespaces joined by a veth pair (rrps_testing.netns_rig).

DDS discovers across the namespaces for real (multicast on the subnet, or the Fast DDS
discovery server), and the faults are real: the link goes down (``ip link set down``) for 2 s
during teleoperation and during each phase of a climbing step (a browser through a proxy that
adds latency and stalls: test_multihost_browser.py). The stack is rrps_testing.multihost_stack's.
What the robot does is recorded inside its own namespace by rrps_testing.netns_agent and judged
from message stamps (rrps_testing.fault_metrics): every namespace shares the host's wall clock.

Root is needed (``ip netns``): locally without it these tests skip, in CI they fail.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import rrps_testing.multihost_stack as multihost_stack
import rrps_testing.netns_rig as netns_rig
from rrps_climbing.path_brake import brake_time
from rrps_description.geometry import load_robot
from rrps_description.motion_limits import stream_limits
from rrps_interfaces.climb import ClimbState, PauseReason, PhaseAction
from rrps_interfaces.teleop import TeleopCode
from rrps_runtime.supervision import start_child
from rrps_testing.agent_handle import AgentHandle
from rrps_testing.ci import require
from rrps_testing.fault_metrics import (
    both_open,
    climb,
    first,
    gripper_openings,
    in_window,
    last_stamp,
    length_change,
    pose_change,
    teleop,
)
from rrps_testing.multihost_stack import (
    DEADLINE,
    MASTER,
    OPERATOR_RECORD,
    ROBOT_RECORD,
    SETTLE,
    STILL,
    brake_settle,
)
from rrps_testing.multihost_stack import fail_with_logs as _fail_with_logs
from rrps_testing.netns import netns_supported, rig_namespaces, wait
from rrps_testing.netns_rig import Rig

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.netns]
rig_factory = netns_rig.rig_factory  # the fixture
stack = multihost_stack.stack  # the fixture

LINK_DOWN = 2.0            # s, each outage
COMMAND_TIMEOUT = 0.1      # s, the IK node's and the driver's (their default)
STATE_TIMEOUT = 0.2        # s, teleop's slave-pose timeout (default)
OPERATOR_TIMEOUT = 0.5     # s, the climb node's operator-link timeout (default)


def _engaged(agent: AgentHandle, since: float = -math.inf) -> bool:
    rows = agent.records('teleop/status', since)
    return bool(rows) and teleop(rows[-1]).engaged


def _moved(agent: AgentHandle, since: float, distance: float) -> bool:
    poses = agent.records('pose', since)
    return len(poses) > 1 and pose_change(poses, poses[0]['stamp'], math.inf) > distance


# --- the rig itself ---------------------------------------------------------------------------

def test_the_rig_removes_every_namespace_and_process_it_made_also_on_failure(ros_domain_id, tmp_path):
    ok, reason = netns_supported()
    require(ok, reason)
    rig = Rig(ros_domain_id, log_dir=tmp_path)
    with pytest.raises(RuntimeError, match='a failing test'):
        with rig:
            assert {rig.robot, rig.operator} <= set(rig_namespaces())
            # the namespaces hold only their loopback and their end of the veth pair
            assert sorted(rig.links('robot')) == ['lo', 'veth0']
            assert sorted(rig.links('operator')) == ['lo', 'veth1']
            rig.start('robot', 'sleeper', ['sleep', '600'])
            # a process that escapes its process group (a new session): found by its namespace
            rig.start('operator', 'escapee', ['sh', '-c', 'setsid sleep 600 & exec sleep 600'])
            assert wait(lambda: len(subprocess.run(['ip', 'netns', 'pids', rig.operator],
                                                   capture_output=True, text=True).stdout.split()) == 2,
                        10.0)
            raise RuntimeError('a failing test')
    assert rig.leftovers() == []
    assert not {rig.robot, rig.operator} & set(rig_namespaces())


# --- discovery across the link ----------------------------------------------------------------

def _teleop_drives_the_robot(rig: Rig, robot: AgentHandle, operator: AgentHandle) -> None:
    """The operator station's teleop (the only target_pose publisher) moves the robot."""
    operator.send({'deadman': True})
    t0 = time.time()
    if not wait(lambda: _engaged(operator, t0) and _moved(robot, t0, 0.002), DEADLINE):
        _fail_with_logs(rig, 'teleop did not drive the robot across the link')
    assert robot.records('target_pose', t0) and robot.records('actuators/command', t0)
    operator.send({'deadman': False})


def test_the_operators_teleop_drives_the_robot_through_a_fast_dds_discovery_server(rig_factory):
    """ROS_DISCOVERY_SERVER: the pinned wheel's fast-discovery-server on the robot host."""
    rig = rig_factory('server')
    robot = rig.agent('robot', record=ROBOT_RECORD)
    operator = rig.agent('operator', record=OPERATOR_RECORD)
    # Both agents exist and publish heartbeats, but clients of an absent server discover
    # nothing (multicast discovery would have matched them within a second).
    time.sleep(3.0)
    assert not robot.records('rig/heartbeat') and not operator.records('rig/heartbeat')
    rig.start_discovery_server()
    assert wait(lambda: robot.records('rig/heartbeat') and operator.records('rig/heartbeat'),
                DEADLINE), 'the agents never discovered each other through the server'
    rig.start_driver()
    rig.start_robot_nodes()
    rig.start_operator(**MASTER)
    assert wait(lambda: robot.records('pose') and operator.records('teleop/status'), DEADLINE)
    _teleop_drives_the_robot(rig, robot, operator)


def test_the_operators_teleop_drives_the_robot_across_the_link_with_multicast_discovery(stack):
    """ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET on the rig's link, and nothing leaves the rig."""
    stack.reset()
    rig, robot, operator = stack.rig, stack.robot, stack.operator
    assert wait(lambda: robot.records('rig/heartbeat') and operator.records('rig/heartbeat'), DEADLINE)
    # An agent in the root namespace on the rig's domain id (DDS on loopback, as every other
    # test) and the rig's agents never meet.
    env = {**os.environ, 'ROS_DOMAIN_ID': str(rig.domain_id), 'PYTHONUNBUFFERED': '1',
           'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    env.pop('ROS_DISCOVERY_SERVER', None)
    outsider = AgentHandle('root', start_child(
        [sys.executable, '-m', 'rrps_testing.netns_agent',
         '--name', 'root', '--record', 'pose', '--ros-args', '-r', '__ns:=/rrps'],
        env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1))
    try:
        assert outsider.ready.wait(DEADLINE)
        t0 = time.time()
        time.sleep(3.0)
        assert not outsider.records('rig/heartbeat') and not outsider.records('pose'), \
            'the root namespace saw the rig'
        assert not [r for a in (robot, operator) for r in a.records('rig/heartbeat', t0)
                    if r['source'] == 'root'], 'the rig saw the root namespace'
    finally:
        outsider.process.terminate()
        outsider.process.wait(10)
    counters = rig.interface_counters('robot')['veth0']
    _teleop_drives_the_robot(rig, robot, operator)
    after = rig.interface_counters('robot')['veth0']
    assert after['tx']['bytes'] > counters['tx']['bytes'] and after['rx']['bytes'] > counters['rx']['bytes']
    # each namespace holds its loopback and its end of the veth pair, and routes only its
    # subnet, multicast on the veth and IPv6 link-local: no way out of the rig
    assert sorted(rig.links('robot')) == ['lo', 'veth0'] and sorted(rig.links('operator')) == ['lo', 'veth1']
    for host in ('robot', 'operator'):
        dst = {r.get('dst') for r in rig.routes(host) if r.get('table') in (None, 'main')}
        assert dst <= {rig.subnet, '224.0.0.0/4', 'fe80::/64'}, dst


# --- link loss during teleoperation -----------------------------------------------------------

MAX_LINEAR_SPEED = 0.05    # m/s, teleop's slave speed limit (default)


def _no_jump(robot: AgentHandle, operator: AgentHandle, since: float) -> None:
    """The first target after ``since`` starts from the robot's pose: a clutch, no jump."""
    engaged = first(operator.records('teleop/status'), lambda r: teleop(r).engaged, since)
    target = first(robot.records('target_pose'), lambda r: True, since)
    assert engaged is not None and target is not None
    here = [r for r in robot.records('pose') if r['t'] <= target['t']][-1]
    jump = float(np.linalg.norm(np.subtract(target['p'], here['p'])))
    allowed = MAX_LINEAR_SPEED * max(target['stamp'] - engaged['t'] + 0.05, 0.0) + 0.5e-3
    assert jump <= allowed, (jump, allowed)

def test_link_loss_during_teleop_holds_the_robot_and_a_held_deadman_reengages_as_a_clutch(stack):
    stack.reset()
    rig, robot, operator = stack.rig, stack.robot, stack.operator
    operator.send({'deadman': True})
    t0 = time.time()
    if not wait(lambda: _engaged(operator, t0) and _moved(robot, t0, 0.002), DEADLINE):
        _fail_with_logs(rig, 'teleop never engaged across the link')

    # 1. The link drops for 2 s while the operator holds the deadman and moves the master.
    t_down = rig.link(False)
    time.sleep(LINK_DOWN)
    t_up = rig.link(True)
    assert wait(lambda: _engaged(operator, t_up) and robot.records('target_pose', t_up + 1.0),
                DEADLINE), 'teleop did not re-engage once the link was back'
    time.sleep(1.5)

    # The robot holds: no command sent after the link went down reached it ...
    newest = last_stamp(robot.records('actuators/command'), t_down, t_up)
    assert newest is None or newest <= t_down + COMMAND_TIMEOUT, newest - t_down
    assert not in_window(robot.records('target_pose'), t_down + COMMAND_TIMEOUT, t_up, by='stamp')
    # ... it stops where it is (the last command, reached within the actuators' lag) ...
    states = robot.records('actuators/state')
    assert in_window(states, t_down + SETTLE, t_up, by='stamp'), 'no robot state during the outage'
    assert length_change(states, t_down + SETTLE, t_up) < STILL
    assert length_change(states, t_down, t_up) < 0.003  # at most the last commands' lag
    # ... never opens a gripper ...
    grippers = robot.records('grippers/state')
    assert gripper_openings(grippers, t_down, t_up) == 0 and not both_open(grippers)
    # ... and the operator station knows why: the slave's state is lost, teleop disengaged.
    during = [teleop(r) for r in operator.records('teleop/status', t_down, t_up)]
    assert any(s.code is TeleopCode.SLAVE_STATE_LOST and not s.engaged for s in during)
    assert not any(teleop(r).engaged for r in operator.records('teleop/status', t_down + 1.0, t_up))

    # Re-engaging is a clutch: the commands after the link came back start at the robot's own
    # pose (the first ones may be lost while the link comes up: the first received one is at
    # most the slave's speed limit times its age away), although the master moved on ...
    _no_jump(robot, operator, t_up)
    master = operator.records('master/pose')
    moved_master = np.linalg.norm(np.subtract(
        [r for r in master if r['stamp'] <= t_up][-1]['p'],
        [r for r in master if r['stamp'] <= t_down][-1]['p']))
    assert moved_master > 0.5e-3, 'the master did not move during the outage: no clutch to test'
    # ... and the slave follows the master's motion from there (scale 4), without catching up
    # with where the master went meanwhile (the mapping would then run at its speed limit).
    t_e = first(robot.records('target_pose'), lambda r: True, t_up)['stamp']
    window = [r for r in robot.records('target_pose') if t_e <= r['stamp'] <= t_e + 1.0]
    slave_step = np.linalg.norm(np.subtract(window[-1]['p'], window[0]['p']))
    m0 = [r for r in master if r['stamp'] <= t_e][-1]['p']
    m1 = [r for r in master if r['stamp'] <= window[-1]['stamp']][-1]['p']
    assert slave_step <= 4.0 * np.linalg.norm(np.subtract(m1, m0)) + 1e-3, (slave_step, moved_master)

    # 2. A deadman released during an outage is not remembered: after the link is back the
    # robot does not move until the operator holds the deadman again, and that engage is a
    # clutch too.
    t_down = rig.link(False)
    time.sleep(LINK_DOWN / 2)
    operator.send({'deadman': False})
    time.sleep(LINK_DOWN / 2)
    t_up = rig.link(True)
    time.sleep(2.0)
    t_check = time.time()
    assert not in_window(robot.records('target_pose'), t_down + COMMAND_TIMEOUT, t_check, by='stamp')
    assert length_change(robot.records('actuators/state'), t_down + SETTLE, t_check) < STILL
    status = teleop(operator.records('teleop/status')[-1])
    assert status.code is TeleopCode.DEADMAN_RELEASED and not status.engaged
    operator.send({'deadman': True})
    t_press = time.time()
    assert wait(lambda: _engaged(operator, t_press) and robot.records('target_pose', t_press), DEADLINE)
    _no_jump(robot, operator, t_press)
    assert not both_open(robot.records('grippers/state'))


# --- link loss during each phase of a climbing step -------------------------------------------

LATE = 0.25  # s after a phase began: a drop later than this may come after a release was due
LIMITS = load_robot('pole_climber').motion_limits   # the stack's robot's
#: The longest a gripper of the stack's robot takes to close [s] (its description's gripper_time).
CLOSE_TIME = max(t.close for t in LIMITS.grippers.values())
#: a paused climb brakes its stream along the path this long [s]; the legs settle this long after its last target
BRAKE = brake_time(stream_limits(LIMITS.legs))
STOP_SETTLE = brake_settle(LIMITS.legs)
#: why a climb may pause with the link up (a busy machine) or during an outage (the operator
#: link lost, or first a stall of the robot's processes)
BUSY_PAUSES = (PauseReason.ROBOT_STATE_LOST, PauseReason.OPERATOR_LINK_LOST)
PHASES = ('release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a')


def _climb_status(robot: AgentHandle, since: float = -math.inf):
    rows = robot.records('climb/status', since)
    return climb(rows[-1]) if rows else None


def _step_up(operator: AgentHandle, robot: AgentHandle) -> float:
    """The operator starts a climbing step; the receipt time of its first status."""
    t_call = time.time()
    replies = []

    def started() -> bool:
        replies.append(operator.call('climb/step_up'))
        if replies[-1]['success']:
            return True
        # refused while a busy machine delays the robot's state (asked again, it starts), or
        # an earlier request whose reply was late did start it
        status = _climb_status(robot, t_call)
        return status is not None and status.state in (ClimbState.EXECUTING, ClimbState.PAUSED)
    assert wait(started, DEADLINE, period=0.5), replies[-1]['message']
    # from the step's first status on (an idle one may still come in after the request)
    running = (ClimbState.EXECUTING, ClimbState.PAUSED)
    assert wait(lambda: first(robot.records('climb/status'), lambda r: climb(r).state in running,
                              t_call), DEADLINE)
    return first(robot.records('climb/status'), lambda r: climb(r).state in running, t_call)['t']


def _resume(operator: AgentHandle, robot: AgentHandle) -> float:
    """The operator resumes the paused climb (retried while its link is not confirmed yet)."""
    t = time.time()

    replies = []

    def resumed() -> bool:
        replies.append(operator.call('climb/resume', timeout=10.0))
        return replies[-1]['success']
    assert wait(resumed, DEADLINE, period=0.3), f'the operator could not resume the climb: {replies[-3:]}'
    # it went on (a busy machine may pause it again at once: the caller sees that next)
    assert wait(lambda: first(robot.records('climb/status'),
                              lambda r: climb(r).state is not ClimbState.PAUSED, t), DEADLINE), \
        f'resumed ({replies[-1]}) but: {_climb_history(robot, t - 2.0)}'
    return t


def _longest_gap(records: list[dict], start: float, end: float) -> float:
    """The longest time [s] between consecutive stamps in [start, end] (a publisher's stall)."""
    stamps = sorted(r['stamp'] for r in in_window(records, start, end, by='stamp'))
    return float(np.max(np.diff(stamps))) if len(stamps) > 1 else 0.0


def _climb_history(robot: AgentHandle, since: float) -> list:
    """The climb statuses received since ``since`` (for failure messages)."""
    return [(round(r['t'] - since, 2), climb(r).state.name, climb(r).phase,
             climb(r).pause_reason and climb(r).pause_reason.name)
            for r in robot.records('climb/status', since)]


def test_link_loss_during_each_climb_phase_pauses_the_climb_until_the_operator_resumes_it(stack):
    """The product's choice: a climb pauses (PAUSED, OPERATOR_LINK_LOST, once the operator
    station's teleop/status has been silent for operator_timeout) and waits for the operator's
    climb/resume; it never resumes by itself."""
    stack.reset()
    rig, robot, operator = stack.rig, stack.robot, stack.operator
    t_start = time.time()
    remaining = list(PHASES)
    faults = []
    for _ in range(5):  # climbing steps, until the link went down once in every phase
        t_call = _step_up(operator, robot)
        seen = None
        while True:
            assert wait(lambda: (s := _climb_status(robot, t_call)) is not None and (
                s.state is not ClimbState.EXECUTING or (s.step, s.phase) != seen), DEADLINE)
            status = _climb_status(robot, t_call)
            if status.state is ClimbState.IDLE:
                break
            assert status.state is not ClimbState.FAILED, status.detail
            if status.state is ClimbState.PAUSED:
                # with the link up: a busy machine delayed the robot's state or the operator
                # station's status; the operator resumes
                assert status.pause_reason in BUSY_PAUSES, status
                _resume(operator, robot)
                continue
            seen = (status.step, status.phase)
            if status.phase not in remaining:
                continue
            entered = first(robot.records('climb/status'), lambda r: (
                climb(r).step, climb(r).phase) == seen, t_call)['t']
            fault = {'phase': status.phase, 'step': status.step, 't_down': rig.link(False)}
            fault['late'] = fault['t_down'] - entered > LATE
            if not fault['late'] or status.action is not PhaseAction.RELEASE:
                remaining.remove(status.phase)
            time.sleep(LINK_DOWN)
            fault['t_up'] = rig.link(True)
            # it never resumes by itself: still paused (or done) well after the link is back
            assert wait(lambda: _climb_status(robot, fault['t_up'] + 1.0) is not None, DEADLINE)
            after = _climb_status(robot, fault['t_up'] + 1.0)
            fault['paused'] = next((climb(r) for r in robot.records('climb/status', fault['t_down'])
                                    if climb(r).state is ClimbState.PAUSED), None)
            fault['state_after_link'] = after.state
            if fault['paused'] is not None:
                assert after.state is ClimbState.PAUSED, after
                fault['t_resume'] = _resume(operator, robot)
            else:
                fault['t_resume'] = time.time()
            faults.append(fault)
            seen = (_climb_status(robot).step, _climb_status(robot).phase)
        if not remaining:
            break
    assert not remaining, f'the link never went down during {remaining}'

    targets = robot.records('target_pose')
    states = robot.records('actuators/state')
    grippers = robot.records('grippers/state')
    for f in faults:
        t_down, t_resume = f['t_down'], f['t_resume']
        paused = f['paused']
        if paused is None:
            # the fault came in the last phase: the step completed (both rings gripping, the
            # robot idle) before the operator link was judged lost, and nothing moved after it
            assert f['state_after_link'] is ClimbState.IDLE and f['phase'] == 'grip_a', f
            done = first(robot.records('climb/status'), lambda r: climb(r).state is ClimbState.IDLE, t_down)
            assert length_change(states, done['t'] + SETTLE, t_resume) < STILL
            continue
        # detected as the lost operator link (or, first, as a late robot state on a busy
        # machine: a stall of the robot's processes during the outage)
        assert paused.pause_reason in BUSY_PAUSES, (f, paused)
        # the climb held within the operator timeout: its last target was sent at most
        # operator_timeout after the link went down and a brake along the path later, plus what a
        # busy machine adds: after a late tick (> state_timeout / 2 apart) the climb node waits
        # state_timeout before it judges its inputs' age again, and the longest stall of its ticks itself
        newest = last_stamp(targets, t_down, t_resume)
        f['hold_after'] = newest - t_down if newest is not None else 0.0
        f['stall'] = _longest_gap(targets, t_down - 0.1, newest or t_down)
        bound = OPERATOR_TIMEOUT + BRAKE + STATE_TIMEOUT + f['stall'] + 0.15
        assert f['hold_after'] <= bound, (f, bound)
        held_from = max(t_down, newest or t_down)
        assert not in_window(targets, held_from + 1e-6, t_resume, by='stamp')
        # the robot stood still while paused (once the legs stopped from the stream's speed) and no
        # gripper switched but to close: a close the climb asked for before the link dropped
        # completes in the gripper's close time (closing never lets go; the climb asks for nothing
        # while paused)
        assert in_window(states, held_from + STOP_SETTLE, t_resume, by='stamp'), f
        assert length_change(states, held_from + STOP_SETTLE, t_resume) < STILL, f
        changes = in_window(grippers, held_from + 0.1, t_resume)
        assert all(closed or not before for a, b in zip(changes, changes[1:])
                   for before, closed in zip(a['closed'].values(), b['closed'].values())), f
        switched = [b['t'] for a, b in zip(changes, changes[1:]) if a['closed'] != b['closed']]
        assert all(t - t_down <= CLOSE_TIME + 0.5 for t in switched), (f, switched)
        # no gripper opened on the lost link (a release waits for the operator station to be
        # heard after the robot settled, so a drop before that holds it)
        f['openings'] = gripper_openings(grippers, t_down, t_resume)
        if not f['late']:
            assert f['openings'] == 0, f
    assert not both_open(grippers)
    assert ClimbState.FAILED not in {climb(r).state for r in robot.records('climb/status', t_start)}
    reasons = [f['paused'].pause_reason for f in faults if f['paused'] is not None]
    assert PauseReason.OPERATOR_LINK_LOST in reasons, reasons
    print('climb link faults (phase, hold after [s], climb stall [s], openings, paused in, reason, late):',
          [(f['phase'], round(f.get('hold_after', 0.0), 3), round(f.get('stall', 0.0), 3),
            f.get('openings'), f['paused'] and f['paused'].phase,
            f['paused'] and f['paused'].pause_reason.name, f['late']) for f in faults])
