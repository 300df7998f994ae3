"""The scripted operator of the demo asks again for a climbing step that climb_node refused, as a
person at the viewer does, and says so: the first request comes while the operator station reports
teleoperation engaged (climb_node refuses it), the station then reports it released, and the
second request is accepted. Driver, IK, FK and climb_node run in this test's process."""

from __future__ import annotations

import threading

import pytest
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped

from rrps_bringup.operator import ScriptedOperator
from rrps_interfaces.teleop import TeleopCode, TeleopStatus
from rrps_testing.climb_stack import climb_stack
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def _teleop_status(engaged: bool) -> DiagnosticStatus:
    code = TeleopCode.NO_WARNING if engaged else TeleopCode.DEADMAN_RELEASED
    values = TeleopStatus(code=code, engaged=engaged).to_values()
    return DiagnosticStatus(message=code.name, values=[KeyValue(key=k, value=v) for k, v in values.items()])


class _Operator(ScriptedOperator):
    """Records what it says; at its first refusal the station releases teleoperation, and the
    operator goes on once climb_node has heard that twice."""

    def __init__(self, release, **kwargs):
        super().__init__('operator', **kwargs)
        self.said: list[str] = []
        self._release = release

    def _say(self, text: str) -> None:
        self.said.append(text)
        if 'refused' in text and len(self.said) == 1:
            self._release()


def test_a_refused_step_request_is_asked_again_and_the_check_says_why(ros_context):
    probe = Probe(context=ros_context)
    poses = probe.collect(PoseStamped, 'pose')
    station = probe.publisher(DiagnosticStatus, 'teleop/status')
    heard = probe.collect(DiagnosticStatus, 'teleop/status')
    engaged = {'now': True}
    probe.create_timer(0.1, lambda: station.publish(_teleop_status(engaged['now'])))

    def release() -> None:
        engaged['now'] = False
        n = len(heard)
        assert wait_for(lambda: len(heard) > n + 1)

    stop = threading.Event()
    operator = _Operator(release, context=ros_context)
    # the refusal under test is the teleop one: a robot state late on a busy machine (CI saw grippers/state
    # 1.22 s old against the harness's 1 s) must not stand in for it, so the state may be 5 s old here
    nodes = climb_stack(ros_context, climb={'structure': 'pole', 'speed': 0.05, 'step_length': 0.06, 'start': 0.2,
                                            'state_timeout': 5.0})
    accepted = {}

    def ask() -> None:   # the script stops once the step is accepted: its execution is not this test's
        checks, _ = operator.climb_step(stop)
        accepted['check'] = checks[0]
    thread = threading.Thread(target=ask)
    with Spinner(ros_context, [*nodes, probe, operator]):
        try:
            assert wait_for(lambda: poses and operator._step.ready())
            assert wait_for(lambda: station.get_subscription_count() >= 2)   # climb_node and the operator
            n = len(heard)
            assert wait_for(lambda: len(heard) > n + 1)   # climb_node has the engaged status
            thread.start()
            assert wait_for(lambda: len(operator.said) >= 2, timeout=60.0), operator.said
        finally:
            stop.set()
            if thread.is_alive():
                thread.join()
    first, second = operator.said[:2]
    assert first.startswith('climb/step') and 'refused: teleoperation is engaged' in first, first
    assert 'refused' not in second, second
    text, passed = accepted['check']
    assert passed and text == 'climb step up accepted after 1 refusal(s): refused: teleoperation is engaged', text
