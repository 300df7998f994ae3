"""A test-side node that watches and operates a driver_node: its status, state, grippers, and
its lifecycle, fault-reset and gripper services (what an operator does at the viewer)."""

from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from rrps_interfaces.driver import GRIPPERS_STATE, RESET_FAULTS, DriverStatus, gripper_service
from rrps_interfaces.kinematics import ACTUATORS_STATE
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_testing.ros_harness import DEADLINE, Probe

__all__ = ['DriverProbe']


class DriverProbe(Probe):
    """Collects driver_node's statuses (time, level, message, DriverStatus), ``actuators/state``
    and ``grippers/state`` (stamped with the monotonic clock), and calls its services."""

    def __init__(self, *, context, namespace: str):
        super().__init__(context=context, name='driver_probe', namespace=namespace)
        self.states = self.collect(JointState, ACTUATORS_STATE, stamped=True)
        self.grippers = self.collect(JointState, GRIPPERS_STATE, stamped=True)
        self.statuses: list[tuple[float, int, str, DriverStatus]] = []
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, 100)
        self._change_state = self.create_client(ChangeState, 'driver_node/change_state')
        self._reset = self.create_client(Trigger, RESET_FAULTS)
        self._grippers = {ring: self.create_client(SetBool, gripper_service(ring)) for ring in ('ring_a', 'ring_b')}

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = time.monotonic()
        for status in msg.status:
            if source_node(status.name) == 'driver_node':
                values = DriverStatus.from_key_values(status.values)
                with self._lock:
                    self.statuses.append((now, status.level[0] if isinstance(status.level, bytes) else status.level,
                                          status.message, values))

    def latest(self) -> tuple[float, int, str, DriverStatus] | None:
        with self._lock:
            return self.statuses[-1] if self.statuses else None

    def _call(self, client, request, timeout: float):
        if not client.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f'{client.srv_name} not offered')
        future = client.call_async(request)
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.01)
        if not future.done():
            raise TimeoutError(f'{client.srv_name}: no answer in {timeout} s')
        return future.result()

    def activate(self, timeout: float = DEADLINE) -> bool:
        return self._call(self._change_state, ChangeState.Request(
            transition=Transition(id=Transition.TRANSITION_ACTIVATE)), timeout).success

    def deactivate(self, timeout: float = DEADLINE) -> bool:
        return self._call(self._change_state, ChangeState.Request(
            transition=Transition(id=Transition.TRANSITION_DEACTIVATE)), timeout).success

    def reset_faults(self, timeout: float = DEADLINE) -> tuple[bool, str]:
        answer = self._call(self._reset, Trigger.Request(), timeout)
        return answer.success, answer.message

    def set_gripper(self, ring: str, close: bool, timeout: float = DEADLINE) -> tuple[bool, str]:
        answer = self._call(self._grippers[ring], SetBool.Request(data=close), timeout)
        return answer.success, answer.message
