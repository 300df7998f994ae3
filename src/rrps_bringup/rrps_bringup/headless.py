"""The scripted operator of ``rrps-demo --headless``: a teleop session and a climb, no browser.

It uses the same topics and services as a person at the viewer: the teleop session of
:class:`rrps_bringup.operator.ScriptedOperator` (the handle, the deadman), then
``climb/step_up`` and ``climb/resume``; it checks the robot's answer on ``pose``,
``teleop/status``, ``climb/status`` and ``odometry/*``.

Like a person, it resumes a climbing step that paused (the robot's state or the operator link
was late: the step holds, see ``PauseReason``) once the step accepts the resume, at most
:data:`MAX_RESUMES` times, and says so: on a machine too busy to keep the state fresh the
summary shows the pauses rather than hiding them.
"""

from __future__ import annotations

import threading
import time

from std_srvs.srv import Trigger

from rrps_bringup.operator import WAIT, ScriptedOperator, print_summary
from rrps_interfaces.climb import CLIMB_RESUME, CLIMB_STEP_UP, ClimbState, odometry_topic

#: Master handle displacement of the scripted session [m] (the slave moves translation_scale x).
HANDLE_STEP = 0.004
#: Most resumes of a paused climbing step the scripted operator makes.
MAX_RESUMES = 5
#: Longest wait [s] for a requested climbing step to start: its preview runs first.
PREVIEW_WAIT = 120.0


class DemoScript(ScriptedOperator):
    """Plays the operator; :meth:`run` returns True when every check passed."""

    def __init__(self, **kwargs):
        super().__init__('demo_script', **kwargs)
        self._step_up = self.create_client(Trigger, CLIMB_STEP_UP)
        self._resume = self.create_client(Trigger, CLIMB_RESUME)

    def run(self, stop: threading.Event, *, viewer=None) -> bool:
        """The scripted session; prints each step and returns overall success."""
        checks = self.wait_until_up(stop)
        if checks[0][1]:
            checks += self.teleop_session(stop, (0.0, 0.0, HANDLE_STEP), 'up')
        if not stop.is_set():
            checks += self._climb(stop)
        if viewer is not None:
            drawn = viewer.viewer.frames_drawn
            checks.append((f'viewer drew {drawn} frames at {viewer.url}', drawn > 0))
        self._say('summary:')
        return print_summary(checks)

    def _climb(self, stop: threading.Event) -> list[tuple[str, bool]]:
        if not self._step_up.wait_for_service(timeout_sec=WAIT):
            return [('climb/step_up service available', False)]
        before = {ring: self._position(odometry_topic(ring)) for ring in ('ring_a', 'ring_b')}
        future = self._step_up.call_async(Trigger.Request())
        got = self._wait(future.done, WAIT, stop)
        response = future.result() if got else None
        accepted = response is not None and response.success
        self._say(f'climb/step_up -> {response.message if response is not None else "no answer"!r}')
        checks = [('climb step up accepted', accepted)]
        if not accepted:
            return checks
        def state() -> ClimbState | None:
            status = self._climb_state()
            return None if status is None else status.state

        def started_or_refused() -> bool:   # a step is previewed (IDLE) before it executes
            status = self._climb_state()
            return status is not None and (status.state is not ClimbState.IDLE
                                           or (status.refusal is not None and not status.previewing))

        seen_executing = self._wait(started_or_refused, PREVIEW_WAIT, stop) and state() is not ClimbState.IDLE
        if not seen_executing:
            final = self._climb_state()
            self._say(f'climb step did not start: {final.detail if final is not None else "no climb status"}')
            return checks + [('climb step started after its preview', False)]
        t0 = time.monotonic()
        pauses = []
        while True:
            done = self._wait(lambda: state() in (ClimbState.IDLE, ClimbState.FAILED, ClimbState.PAUSED),
                              120.0, stop)
            final = self._climb_state()
            if not done or final.state is not ClimbState.PAUSED or len(pauses) >= MAX_RESUMES:
                break
            pauses.append(final.pause_reason.value)
            self._say(f'climb paused ({final.detail}); resuming')
            if not self._resume_climb(stop):
                break
        self._say(f'climb finished in {time.monotonic() - t0:.1f} s: {final.state.value}, '
                  f'{final.detail}')
        resumed = f' after {len(pauses)} resume(s) ({", ".join(pauses)})' if pauses else ''
        checks.append((f'climb step executed and ended idle{resumed}',
                       seen_executing and done and final.state is ClimbState.IDLE))
        after = {ring: self._position(odometry_topic(ring)) for ring in ('ring_a', 'ring_b')}
        if all(p is not None for p in (*before.values(), *after.values())):
            rise = {ring: float(after[ring][2] - before[ring][2]) for ring in before}
            checks.append((f'both rings climbed: ring_a {rise["ring_a"] * 1e3:+.0f} mm, ring_b '
                           f'{rise["ring_b"] * 1e3:+.0f} mm (world odometry)',
                           min(rise.values()) > 0.01))
        else:
            checks.append(('world odometry of both rings received', False))
        return checks

    def _resume_climb(self, stop: threading.Event) -> bool:
        """Call ``climb/resume`` until the step accepts it (it refuses while the cause lasts);
        True once it executes again."""
        def accepted() -> bool:
            future = self._resume.call_async(Trigger.Request())
            if not self._wait(future.done, WAIT, stop):
                return False
            return bool(future.result() is not None and future.result().success)
        if not (self._resume.wait_for_service(timeout_sec=WAIT) and self._wait(accepted, WAIT, stop)):
            return False
        status = self._climb_state  # the step says it executes again (its status after the resume)
        return self._wait(lambda: status() is not None and status().state is not ClimbState.PAUSED, WAIT, stop)
