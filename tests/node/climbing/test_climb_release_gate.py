"""A climb opens a gripper only on an operator link heard since the robot settled.

The climb node judges the operator station lost after ``operator_timeout`` (0.5 s) of silence of
its ``teleop/status``; a release that was due within that time must not go ahead on a link that
is already gone. Here the operator station falls silent the moment a release phase starts: the
gripper stays closed, the step pauses (OPERATOR_LINK_LOST) in that very phase, and the release
happens only after the operator is back and resumes.
"""

from __future__ import annotations

import time

import pytest
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from rrps_interfaces.climb import ClimbState, ClimbStatus, PauseReason
from rrps_interfaces.driver import gripper_states
from rrps_interfaces.teleop import TeleopCode, TeleopStatus
from rrps_testing.climb_stack import climb_stack
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow]

DEADLINE = 40.0


def _status(msgs) -> ClimbStatus | None:
    return ClimbStatus.from_key_values(msgs[-1].values) if msgs else None


def test_a_release_waits_for_the_operator_link_and_the_step_pauses_without_opening(ros_context):
    nodes = climb_stack(ros_context, driver={'rate': 100.0},   # the node's own operator_timeout
                        climb={'speed': 0.03, 'step_length': 0.05, 'start': 0.2, 'operator_timeout': 0.5})
    climb = nodes[-1]
    probe = Probe(context=ros_context)
    grippers = probe.collect(JointState, 'grippers/state', stamped=True)
    teleop = probe.publisher(DiagnosticStatus, 'teleop/status')
    values = TeleopStatus(code=TeleopCode.DEADMAN_RELEASED, engaged=False).to_values()
    station = {'on': True, 'off_at': None}
    statuses: list = []

    def on_climb_status(msg) -> None:
        statuses.append(msg)
        s = ClimbStatus.from_key_values(msg.values)
        if station['off_at'] is None and s.state is ClimbState.EXECUTING and s.phase == 'release_b':
            station['on'], station['off_at'] = False, time.monotonic()  # the link drops now

    probe.create_subscription(DiagnosticStatus, 'climb/status', on_climb_status, 10)
    probe.create_timer(0.1, lambda: station['on'] and teleop.publish(DiagnosticStatus(
        name='teleop_node', values=[KeyValue(key=k, value=v) for k, v in values.items()])))
    up = probe.create_client(Trigger, 'climb/step_up')
    resume = probe.create_client(Trigger, 'climb/resume')

    def call(client):
        future = client.call_async(Trigger.Request())
        assert wait_for(future.done, DEADLINE)
        return future.result()

    def ring_b_open_since(t: float) -> bool:
        return any(t_rx >= t and not gripper_states(m.name, m.position)['ring_b']
                   for t_rx, m in list(grippers))

    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(lambda: climb.pose is not None and climb.watch.operator_seen(),
                        DEADLINE)
        assert wait_for(lambda: call(up).success, DEADLINE)
        assert wait_for(lambda: station['off_at'] is not None, DEADLINE)
        assert wait_for(lambda: (s := _status(statuses)) is not None and s.state is ClimbState.PAUSED,
                        DEADLINE)
        paused = _status(statuses)
        assert paused.pause_reason is PauseReason.OPERATOR_LINK_LOST
        assert paused.phase == 'release_b', paused  # held in the release, not after it
        wait_for(lambda: False, timeout=1.0)
        assert not ring_b_open_since(station['off_at'] - 0.5), 'ring_b opened on a lost link'
        station['on'] = True                        # the operator is back and resumes
        assert wait_for(lambda: call(resume).success, DEADLINE, period=0.2)
        assert wait_for(lambda: ring_b_open_since(station['off_at']), DEADLINE)

        def finished() -> bool:
            if _status(statuses).state is ClimbState.PAUSED:  # a busy machine: resume again
                call(resume)
            return _status(statuses).state is ClimbState.IDLE
        assert wait_for(finished, DEADLINE, period=0.2), _status(statuses)
    assert not any(ClimbStatus.from_key_values(s.values).state is ClimbState.FAILED for s in statuses)
