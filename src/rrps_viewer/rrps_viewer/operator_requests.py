"""The viewer node's requests to the robot: what an operator's buttons ask of other nodes' services.

:class:`ViewerRequests` holds one client per :class:`OperatorRequest` and sends without blocking; the answer is told
to the browser that asked. The climb, gripper and driver services are the selected robot's (:meth:`select`), the
teleop node's (``MAPPING`` and ``ROBOT``, set atomically) the viewer's namespace's. Runs on the executor's thread.
"""

from __future__ import annotations

import enum
from typing import Callable

from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParametersAtomically
from std_srvs.srv import SetBool, Trigger

from rrps_description.names import RINGS
from rrps_interfaces.climb import CLIMB_RESUME
from rrps_interfaces.driver import gripper_service
from rrps_interfaces.link import namespaced
from rrps_viewer.climb_step_client import ClimbStepClient

__all__ = ['OperatorRequest', 'ViewerRequests', 'TELEOP_PARAMETERS', 'DRIVER_CHANGE_STATE']

#: The teleop node's standard atomic parameter service, relative to the viewer's namespace.
TELEOP_PARAMETERS = 'teleop_node/set_parameters_atomically'
#: The driver's lifecycle service, relative to the viewer's namespace.
DRIVER_CHANGE_STATE = 'driver_node/change_state'


class OperatorRequest(enum.Enum):
    """What an operator's button asks for."""

    STEP_UP = 'climb step up'
    STEP_DOWN = 'climb step down'
    RESUME = 'resume climb'
    GRIPPER = 'gripper'
    DRIVER = 'driver'
    MAPPING = 'mapping'
    ROBOT = 'drive robot'


def _string(name: str, value: str) -> Parameter:
    return Parameter(name=name, value=ParameterValue(type=ParameterType.PARAMETER_STRING,
                                                     string_value=value))


def _double(name: str, value: float) -> Parameter:
    return Parameter(name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE,
                                                     double_value=float(value)))


class ViewerRequests:
    """The service clients behind the operator's buttons (see the module docstring)."""

    def __init__(self, node, *, tell: Callable[[int, str, bool], None], robot: str = ''):
        self._node = node
        self._tell = tell
        self._teleop = node.create_client(SetParametersAtomically, TELEOP_PARAMETERS)
        self._robots: dict[str, dict] = {}
        #: what the ROBOT request's answer does once teleop accepted the switch: ``on_switch(namespace)``
        self.on_switch: Callable[[str], None] = lambda namespace: None
        self.select(robot)

    def select(self, robot: str) -> None:
        """The climb, gripper and driver requests go to the robot in namespace ``robot`` ('':
        the viewer's own) from now on (clients kept for a switch back)."""
        if robot not in self._robots:
            node = self._node
            step = ClimbStepClient(node, robot)
            self._robots[robot] = {
                OperatorRequest.STEP_UP: step, OperatorRequest.STEP_DOWN: step,
                OperatorRequest.RESUME: node.create_client(Trigger, namespaced(CLIMB_RESUME, robot)),
                **{ring: node.create_client(SetBool, namespaced(gripper_service(ring), robot)) for ring in RINGS},
                OperatorRequest.DRIVER: node.create_client(ChangeState, namespaced(DRIVER_CHANGE_STATE, robot))}
        self._clients = self._robots[robot]

    def close(self) -> None:
        """Stop the climbing step's action clients (their threads)."""
        for clients in self._robots.values():
            clients[OperatorRequest.STEP_UP].close()

    def _client(self, kind: OperatorRequest, arg):
        if kind is OperatorRequest.GRIPPER:
            return self._clients[arg[0]]
        return self._clients.get(kind, self._teleop)

    def ready(self, kind: OperatorRequest, ring: str = 'ring_a') -> bool:
        """Whether the service (or action) behind ``kind`` is up (``ring``: which gripper)."""
        client = self._client(kind, (ring, True))
        return client.ready() if isinstance(client, ClimbStepClient) else client.service_is_ready()

    def send(self, kind: OperatorRequest, client_id: int, arg=None) -> None:
        """Send one request: ``arg`` is (ring, close) for GRIPPER, active (bool) for DRIVER,
        (mode, rotation_mode, scale) for MAPPING, the robot's namespace for ROBOT, nothing else
        for the climb requests."""
        client = self._client(kind, arg)
        if isinstance(client, ClimbStepClient):
            what = kind.value
            if not client.ready():
                return self._tell(client_id, f'{what}: {client.name} is not available', False)
            return client.request(+1 if kind is OperatorRequest.STEP_UP else -1,
                                  lambda ok, text: self._tell(client_id, f'{what}: {text}', ok))
        if kind is OperatorRequest.DRIVER:
            what = ('activate' if arg else 'deactivate') + ' driver'
            request = ChangeState.Request(transition=Transition(
                id=Transition.TRANSITION_ACTIVATE if arg else Transition.TRANSITION_DEACTIVATE))
        elif kind is OperatorRequest.GRIPPER:
            ring, close = arg
            request, what = SetBool.Request(data=close), f'{"close" if close else "open"} {ring}'
        elif kind is OperatorRequest.ROBOT:
            what = f'drive {arg or "this namespace"}'
            request = SetParametersAtomically.Request(parameters=[_string('robot_namespace', arg)])
        elif kind is OperatorRequest.MAPPING:
            mode, rotation_mode, scale = arg
            what = f'mapping {mode}/{rotation_mode} ×{scale:g}'
            request = SetParametersAtomically.Request(parameters=[
                _string('mode', mode), _string('rotation_mode', rotation_mode),
                _double('translation_scale', scale)])
        else:
            request, what = Trigger.Request(), kind.value
        if not client.service_is_ready():
            self._tell(client_id, f'{what}: service {client.srv_name} is not available', False)
            return
        client.call_async(request).add_done_callback(
            lambda future: self._answer(kind, client_id, what, future.result(), arg))

    def _answer(self, kind: OperatorRequest, client_id: int, what: str, response, arg) -> None:
        if response is None:
            self._tell(client_id, f'{what}: no response', False)
        elif kind is OperatorRequest.DRIVER:
            self._tell(client_id, f'{what}: ' + ('done' if response.success else
                                                 'refused (not possible from its state)'),
                       response.success)
        elif kind in (OperatorRequest.MAPPING, OperatorRequest.ROBOT):
            result = response.result
            if result.successful and kind is OperatorRequest.ROBOT:
                self.on_switch(arg)
            self._tell(client_id, f'{what}: ' + ('applied' if result.successful
                                                 else f'refused: {result.reason}'),
                       result.successful)
        else:
            self._tell(client_id, f'{what}: {response.message or "done"}', response.success)
