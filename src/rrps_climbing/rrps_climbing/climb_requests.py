"""climb_node's step services (``climb/step_up``, ``climb/step_down``, ``climb/resume``): served on
the node's :class:`~rrps_runtime.action_host.ActionHost` thread, carried out in climb_node's tick,
so that a reply that waits for a step's plan (made in the worker process) never holds the node's
executor, nor the nodes composed with it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from functools import partial

from rclpy.task import Future
from std_srvs.srv import Trigger

from rrps_runtime.action_host import ActionHost

__all__ = ['StepRequests']


class StepRequests:
    """The Trigger services ``services`` (name: the machine's request and its arguments) on
    ``host``; :meth:`take` hands the waiting requests to climb_node's thread, which answers each
    (its Future's result: (success, message))."""

    def __init__(self, host: ActionHost, services: dict[str, tuple[Callable, tuple]]):
        self._lock = threading.Lock()
        self._waiting: list[tuple[Callable, tuple, Future]] = []
        for name, (call, args) in services.items():
            host.node.create_service(Trigger, name, partial(self._serve, call, args))

    async def _serve(self, call, args, request, response):
        """The host's thread: queue the request and reply once climb_node answered it."""
        answer = Future()
        with self._lock:
            self._waiting.append((call, args, answer))
        response.success, response.message = await answer
        return response

    def take(self) -> list[tuple[Callable, tuple, Future]]:
        """climb_node's thread: the requests waiting, oldest first (call, args, answer)."""
        with self._lock:
            waiting, self._waiting = self._waiting, []
        return waiting
