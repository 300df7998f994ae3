"""The climbing step as the ROS 2 action ``climb/step`` (rrps_msgs/action/ClimbStep) over climb_node's
:class:`~rrps_climbing.step_machine.ClimbStepMachine`; goals, feedback and cancel: docs/usage.md
('The ROS interface'). One goal at a time. The server runs on the node's
:class:`~rrps_runtime.action_host.ActionHost` thread, the machine only in climb_node's tick
(:meth:`ClimbAction.tick`): the two hand over under a lock.
"""

from __future__ import annotations

import math
import threading

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.task import Future

from rrps_interfaces.climb import CLIMB_STEP, ClimbPreview, ClimbState
from rrps_runtime.action_host import ActionHost

__all__ = ['ClimbAction', 'FEEDBACK_RATE']

FEEDBACK_RATE = 5.0  # [Hz]


class ClimbAction:
    """``climb/step`` on ``node`` (a ClimbNode) with the action type ``action_type``, served on
    the node's ``host``; ``carry_out`` does what a machine's output asks for (climb_node's)."""

    def __init__(self, node, action_type, carry_out, host: ActionHost):
        self.node, self.type, self.carry_out = node, action_type, carry_out
        self.preview: ClimbPreview | None = None   # the newest preview (climb_node sets it)
        self._lock = threading.Lock()
        self._goal = None            # (goal handle, direction, Future of (outcome, Result)) of the active goal
        self._started_at: int | None = None  # steps_done when its step was asked for
        self._cancel = False
        self._feedback = None
        self.host = host
        self._server = ActionServer(self.host.node, action_type, CLIMB_STEP, execute_callback=self._execute,
                                    goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT)
        self.host.node.create_timer(1.0 / FEEDBACK_RATE, self._publish_feedback)

    # --- the action server's thread ------------------------------------------------------------

    def _on_goal(self, goal) -> GoalResponse:
        with self._lock:
            busy = self._goal is not None
        if busy or goal.direction not in (self.type.Goal.UP, self.type.Goal.DOWN):
            self.node.get_logger().warning(f'{CLIMB_STEP}: goal rejected: '
                                           + ('a step is running' if busy else f'direction {goal.direction}'))
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    async def _execute(self, goal_handle):
        done = Future()
        with self._lock:
            self._goal, self._started_at, self._cancel = (goal_handle, goal_handle.request.direction, done), None, False
        outcome, result = await done
        getattr(goal_handle, outcome)()   # succeed, abort or canceled
        return result

    def _publish_feedback(self) -> None:
        with self._lock:
            goal, feedback = self._goal, self._feedback
            if goal is not None and goal[0].is_cancel_requested:
                self._cancel = True
        if goal is not None and feedback is not None and goal[0].is_active:
            goal[0].publish_feedback(feedback)

    # --- climb_node's thread -------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """Hand the goal's request or cancel to the machine, and its status to the goal."""
        with self._lock:
            goal, started, cancel = self._goal, self._started_at, self._cancel
        if goal is None:
            return
        machine = self.node.machine
        if started is None:
            out = machine.step(int(goal[1]), now)
            self.carry_out(out)
            if not out.reply[0]:
                return self._finish('abort', False, out.reply[1])
            with self._lock:
                self._started_at = machine.steps_done
            return
        if cancel:
            self.carry_out(machine.cancel())
            return self._finish('canceled', False, f'cancelled: {machine.detail}')
        if machine.planning:
            return   # no feedback before the plan is made: the first says what became of it
        status = machine.status()
        with self._lock:
            self._feedback = self._feedback_of(status)
        if status.state is ClimbState.FAILED:
            self._finish('abort', False, status.detail)
        elif status.state is ClimbState.IDLE and not status.previewing:
            done = machine.steps_done > started
            self._finish('succeed' if done else 'abort', done, status.detail)

    def _feedback_of(self, status):
        preview = self.preview
        force = 1.0 - preview.peak_force / preview.max_force if preview and preview.max_force > 0 else math.nan
        return self.type.Feedback(
            state='previewing' if status.previewing else status.state.value, phase=status.phase,
            progress=float(status.phase_index / status.phases) if status.phases else 0.0,
            force_margin=float(force), holding_margin=float(preview.min_margin) if preview else math.nan,
            detail=status.detail)

    def _finish(self, outcome: str, success: bool, message: str) -> None:
        with self._lock:
            goal, self._goal, self._feedback = self._goal, None, None
        result = self.type.Result(success=success, message=message, steps_done=self.node.machine.steps_done)
        goal[2].set_result((outcome, result))

    def close(self) -> None:
        """Destroy the server (the host's thread stopped first: never while it waits on it)."""
        self._server.destroy()
