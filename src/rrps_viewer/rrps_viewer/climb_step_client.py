"""A client of the climbing step (the viewer's buttons, the scripted operator): the action ``climb/step`` where
rrps_msgs is built, else the services ``climb/step_up|step_down``. :meth:`ClimbStepClient.request` does not block and
answers once the step was taken (first feedback) or refused; callbacks run in the thread of an
:class:`~rrps_runtime.action_host.ActionHost`."""

from __future__ import annotations

import threading
from typing import Callable

from std_srvs.srv import Trigger

from rrps_interfaces.climb import CLIMB_STEP, CLIMB_STEP_DOWN, CLIMB_STEP_UP
from rrps_interfaces.link import namespaced
from rrps_runtime.action_host import ActionHost

__all__ = ['ClimbStepClient']


class ClimbStepClient:
    """One step up (+1) or down (-1) of the robot in ``namespace`` ('' : the node's own)."""

    def __init__(self, node, namespace: str = ''):
        self.name = namespaced(CLIMB_STEP, namespace)
        try:
            from rrps_msgs.action import ClimbStep  # optional: built by ./rrps (tools/rrps_msgs)
        except ImportError:
            self.type, self.host, self.name = None, None, namespaced(CLIMB_STEP_UP, namespace)
            self._services = {+1: node.create_client(Trigger, namespaced(CLIMB_STEP_UP, namespace)),
                              -1: node.create_client(Trigger, namespaced(CLIMB_STEP_DOWN, namespace))}
            return
        from rclpy.action import ActionClient
        self.type, self.host = ClimbStep, ActionHost(node)
        self._action = ActionClient(self.host.node, ClimbStep, self.name)
        self.result = None  # the newest goal's result future (the action)
        self._closed = False

    def ready(self) -> bool:
        return self._action.server_is_ready() if self.host else self._services[+1].service_is_ready()

    def request(self, direction: int, on_answer: Callable[[bool, str], None], on_feedback=None) -> None:
        """Ask for one step; ``on_answer(accepted, text)`` once, ``on_feedback(feedback)`` on
        every feedback of the action's goal."""
        if self.host is None:
            self._services[direction].call_async(Trigger.Request()).add_done_callback(
                lambda f: on_answer(*((f.result().success, f.result().message) if f.result() else (False, 'no reply'))))
            return
        answered = threading.Event()

        def answer(accepted: bool, text: str) -> None:
            if not answered.is_set():
                answered.set()
                on_answer(accepted, text)

        def feedback(message) -> None:
            answer(True, message.feedback.detail or message.feedback.state)
            if on_feedback is not None:
                on_feedback(message.feedback)

        def result(future) -> None:
            done = future.result()
            answer(done is not None and done.result.success, done.result.message if done else 'no result')

        def goal(future) -> None:
            handle = future.result()
            if handle is None or not handle.accepted:
                return answer(False, 'refused: another climbing step runs')
            self.result = handle.get_result_async()
            self.result.add_done_callback(result)
        self._action.send_goal_async(self.type.Goal(direction=direction), feedback_callback=feedback
                                     ).add_done_callback(goal)

    def close(self) -> None:
        """Destroy the action client and stop its thread (a second call does nothing)."""
        if self.host is not None and not self._closed:
            self._closed = True
            self.host.stop()   # never destroy the client while the host's thread waits on it
            self._action.destroy()
            self.host.close()
