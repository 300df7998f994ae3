"""The whole rrps stack on a multi-host rig (:mod:`rrps_testing.netns_rig`) for the multi-host
system tests: a robot host (driver, IK, FK, climbing) and an operator station (master, teleop,
viewer), an agent on each (:mod:`rrps_testing.netns_agent`), at rates two shared cores keep up
with; and the module-scoped fixture ``stack`` that starts it once for a test module."""

from __future__ import annotations

import time

import numpy as np
import pytest

from rrps_climbing.step_io import StepConfig
from rrps_description.motion_limits import ActuatorLimits
from rrps_hardware.setpoints import DRIVER_PERIOD, stream_setpoints
from rrps_interfaces.climb import ClimbState
from rrps_testing.ci import require
from rrps_testing.fault_metrics import climb, teleop
from rrps_testing.netns import netns_supported, wait
from rrps_testing.netns_rig import Rig
from rrps_testing.paused_stream import paused_stream

__all__ = ['Stack', 'stack', 'fail_with_logs', 'brake_settle',
           'DEADLINE', 'SETTLE', 'STILL', 'ROBOT_RECORD', 'OPERATOR_RECORD',
           'TOKEN', 'VIEWER_PORT', 'MASTER']

DEADLINE = 90.0            # generous: two cores shared with other jobs
SETTLE = 0.5               # s, the actuators' lag settles (20 ms time constant) well within it
STILL = 20e-6              # m, "does not move": leg lengths within 20 um
ROBOT_RECORD = ('pose', 'actuators/command', 'actuators/state', 'grippers/state', 'target_pose',
                'climb/status')
OPERATOR_RECORD = ('teleop/status', 'master/pose', 'teleop/enable', 'operator/round_trip_time')
TOKEN = 'multihost-token'
VIEWER_PORT = 8080             # inside the operator namespace: its own port space


#: short steps; the robot settles 0.4 s at each gripper's pose before switching it, so that the
#: link reliably drops before a release is due (the test's reaction takes up to ~0.2 s)
CLIMB_PARAMS = {'climb_node:step_length': 0.05, 'climb_node:speed': 0.025,
                'climb_node:settle_time': 0.4}
#: Both "hosts", both agents and a browser share two cores: master and driver at 50 Hz, the scene
#: at 5 Hz, the viewer in a process of its own (it never holds up master's and teleop's timers)
MASTER = {'master_node:trajectory': 'circle', 'master_node:rate': 50.0}
DRIVER_RATE = 50.0
VIEWER_PARAMS = {'viewer_node:host': '127.0.0.1', 'viewer_node:port': VIEWER_PORT,
                 'viewer_node:token': TOKEN, 'viewer_node:render_rate': 5.0}


def brake_settle(limits: ActuatorLimits) -> float:
    """How long [s] after a paused climb's last target the legs may still move: the driver's
    jerk-limited setpoints (rrps_hardware.setpoints) reach the braked stream's last target
    (rrps_testing.paused_stream) shortly after it; then the actuators' lag settles (:data:`SETTLE`)."""
    period = StepConfig().period
    commands = paused_stream(limits, period)
    setpoints = stream_setpoints(commands, period, limits, settle=5.0)[:, 0]
    moving = np.flatnonzero(np.abs(setpoints - commands[-1, 0]) > STILL / 2)
    last_command = (len(commands) - 1) * period
    return float(max(moving[-1] * DRIVER_PERIOD - last_command, 0.0) + SETTLE)


class Stack:
    """The whole stack on a rig: driver, robot nodes, operator station (master, teleop, viewer)
    and an agent on each host."""

    def __init__(self, rig: Rig, state_file: str = ''):
        self.rig = rig
        rig.start_driver(state_file=state_file, rate=DRIVER_RATE)
        rig.start_robot_nodes(**CLIMB_PARAMS)
        rig.start_operator(**MASTER)
        rig.python('operator', 'viewer', ['-m', 'rrps_bringup.compose', 'viewer_node',
                                          *rig.ros_args({'robot': 'pole_climber', **VIEWER_PARAMS})])
        self.robot = rig.agent('robot', record=ROBOT_RECORD)
        self.operator = rig.agent('operator', record=OPERATOR_RECORD)
        if not wait(lambda: self.robot.records('pose') and self.operator.records('teleop/status')
                    and self.robot.records('climb/status'), DEADLINE):
            fail_with_logs(rig, 'the stack did not come up')

    def reset(self) -> None:
        """A known state between tests: link up, deadman released, teleop disengaged, no climb."""
        if not self.rig.link_up:
            self.rig.link(True)
        self.operator.send({'deadman': False})
        t = time.time()
        assert wait(lambda: (r := self.operator.records('teleop/status', t + 0.3))
                    and not teleop(r[-1]).engaged, DEADLINE)
        def idle() -> bool:
            rows = self.robot.records('climb/status')
            state = climb(rows[-1]).state if rows else None
            if state is ClimbState.PAUSED:
                self.operator.call('climb/resume', timeout=10.0)
            return state in (ClimbState.IDLE, ClimbState.FAILED)
        assert wait(idle, DEADLINE, period=0.3)


@pytest.fixture(scope='module')
def stack(tmp_path_factory):
    """One rig and stack for the tests of a test module (that binds this fixture) that need no
    other set-up (starting the processes is most of a test's time on a busy machine); each test
    calls ``reset`` first."""
    from rrps_testing.ci import next_domain_id
    ok, reason = netns_supported()
    require(ok, reason)
    log_dir = tmp_path_factory.mktemp('multihost')
    rig = Rig(next_domain_id(), discovery='subnet', log_dir=log_dir)
    try:
        rig.__enter__()
        yield Stack(rig, state_file=str(log_dir / 'hardware.json'))
    finally:
        rig.close()
    assert rig.leftovers() == []


def fail_with_logs(rig: Rig, message: str) -> None:
    """Fail the test with ``message`` and the tail of each of the rig's process logs."""
    logs = '\n'.join(f'--- {name}\n{rig.log_tail(name)}' for name in rig.processes)
    pytest.fail(f'{message}\n{logs}')
