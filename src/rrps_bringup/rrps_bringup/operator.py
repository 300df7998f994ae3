"""The scripted operator of the headless demos: a teleop session as a person at the viewer plays it.

:class:`ScriptedOperator` (used by :mod:`rrps_bringup.headless`, :mod:`rrps_bringup.scenario_script` and
:mod:`rrps_bringup.frame_script`) drives the operator's topics (the handle, the deadman) and reads the robot's answer.
Like a person it resumes a paused climbing step, at most :data:`MAX_RESUMES` times, and the summary says so.
"""

from __future__ import annotations

import threading
import time
from collections import Counter

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from rrps_bringup.step_report import ExecutionClock
from rrps_interfaces.climb import (
    CLIMB_PREVIEW,
    CLIMB_RESUME,
    CLIMB_STATUS,
    ClimbPreview,
    ClimbState,
    ClimbStatus,
    odometry_topic,
)
from rrps_interfaces.kinematics import POSE
from rrps_interfaces.teleop import (
    MASTER_FRAME,
    MASTER_POSE,
    MASTER_TARGET_POSE,
    TELEOP_ENABLE,
    TELEOP_STATUS,
    TeleopStatus,
)
from rrps_runtime.messages import pose_from_msg, pose_to_msg, stamp_to_seconds
from rrps_runtime.qos import COMMAND_QOS, LATCHED_QOS, STATE_QOS
from rrps_viewer.climb_step_client import ClimbStepClient

__all__ = ['ScriptedOperator', 'Check', 'WAIT', 'MAX_RESUMES', 'PREVIEW_WAIT', 'print_summary']

#: Deadline [s] of each thing the script waits for (it ends as soon as it happened): generous,
#: so that a machine slowed by other jobs delays the session rather than failing it.
WAIT = 30.0

#: Most resumes of a paused climbing step the scripted operator makes.
MAX_RESUMES = 5
#: Longest wait [s] for the robot to stand still after the deadman's release: the stream's jerk-limited stop
#: (``rrps_teleop.target_stream.stopping_time``), the driver a command period behind, a busy machine delaying both.
STOP_WAIT = 2.0
#: How many times the teleop session moves the handle when a clutch interrupts the motion (a late master sample).
MOVE_ATTEMPTS = 4
#: How many times the scripted operator asks for a climbing step that is refused, and the pause [s] between: a
#: refusal for a state that came late on a busy machine passes, as a person asking again sees.
STEP_REQUESTS = 3
STEP_RETRY = 1.0
#: Longest wait [s] for a requested climbing step's answer and for the step to start: it is planned and
#: previewed first, in the climb node's worker process, which after a start may still be loading its kernels.
PREVIEW_WAIT = 120.0

#: One check of a scripted session: (what, passed).
Check = tuple[str, bool]


def print_summary(checks: list[Check]) -> bool:
    """Print each check as [PASS]/[FAIL]; True when there are checks and every one passed."""
    for text, passed in checks:
        print(f'  [{"PASS" if passed else "FAIL"}] {text}', flush=True)
    return bool(checks) and all(passed for _, passed in checks)


class ScriptedOperator(Node):
    """Plays the operator at the master (see the module docstring)."""

    def __init__(self, name: str, **kwargs):
        super().__init__(name, **kwargs)
        self._lock = threading.Lock()
        self._latest: dict[str, object] = {}
        self._disengaged: tuple[int, str] = (0, '')
        self.climb_clock = ExecutionClock()  # the time climbs spent executing and paused
        for topic in (POSE, MASTER_POSE, odometry_topic('ring_a'), odometry_topic('ring_b')):
            self.create_subscription(PoseStamped, topic,
                                     lambda m, topic=topic: self._store(topic, m), STATE_QOS)
        for topic in (TELEOP_STATUS, CLIMB_STATUS):
            self.create_subscription(DiagnosticStatus, topic,
                                     lambda m, topic=topic: self._store(topic, m), STATE_QOS)
        self.create_subscription(DiagnosticStatus, CLIMB_PREVIEW,
                                 lambda m: self._store(CLIMB_PREVIEW, m), LATCHED_QOS)
        self._enable = self.create_publisher(Bool, TELEOP_ENABLE, COMMAND_QOS)
        self._step = ClimbStepClient(self)   # the climb/step action (or climb/step_up without rrps_msgs)
        self._resume = self.create_client(Trigger, CLIMB_RESUME)
        self._handle = self.create_publisher(PoseStamped, MASTER_TARGET_POSE, COMMAND_QOS)

    def destroy_node(self) -> None:
        self._step.close()
        super().destroy_node()

    def _store(self, topic: str, msg) -> None:
        with self._lock:
            self._latest[topic] = msg
            if topic == TELEOP_STATUS:
                # Every disengagement counts, also one shorter than the script's polling period.
                status = TeleopStatus.from_key_values(msg.values)
                if not status.engaged:
                    self._disengaged = (self._disengaged[0] + 1, status.code.name)
                self._on_teleop_status(status)
            elif topic == CLIMB_STATUS:
                self.climb_clock.update(ClimbStatus.from_key_values(msg.values).state, time.monotonic())

    def _on_teleop_status(self, status: TeleopStatus) -> None:
        """Each teleop/status received (under the lock): for subclasses that watch the codes."""

    def _disengagements(self) -> tuple[int, str]:
        """(teleop/status messages received with the mapping disengaged, the last one's code)."""
        with self._lock:
            return self._disengaged

    def _get(self, topic: str):
        with self._lock:
            return self._latest.get(topic)

    def _wait(self, predicate, timeout: float, stop: threading.Event, every=None) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not stop.is_set():
            if every is not None:
                every()
            if predicate():
                return True
            time.sleep(0.05)
        return bool(predicate())

    def _position(self, topic: str) -> np.ndarray | None:
        msg = self._get(topic)
        return None if msg is None else pose_from_msg(msg)[0]

    def _teleop(self) -> TeleopStatus | None:
        msg = self._get(TELEOP_STATUS)
        return None if msg is None else TeleopStatus.from_key_values(msg.values)

    def _climb_state(self) -> ClimbStatus | None:
        msg = self._get(CLIMB_STATUS)
        return None if msg is None else ClimbStatus.from_key_values(msg.values)

    def _climb_account(self) -> str:
        """What climb_node's newest status says, for a request it did not answer."""
        status = self._climb_state()
        if status is None:
            return 'no climb status received'
        return f'climb status: {status.state.value}{" (previewing)" if status.previewing else ""}, {status.detail!r}'

    def _climb_preview(self) -> ClimbPreview | None:
        msg = self._get(CLIMB_PREVIEW)
        return None if msg is None else ClimbPreview.from_key_values(msg.values)

    def _engaged(self) -> bool | None:
        status = self._teleop()
        return None if status is None else status.engaged

    @staticmethod
    def _say(text: str) -> None:
        print(f'rrps demo --headless: {text}', flush=True)

    def wait_until_up(self, stop: threading.Event) -> list[Check]:
        """Wait for the robot's and the master's FK poses."""
        ok = self._wait(lambda: self._get(POSE) is not None and self._get(MASTER_POSE) is not None,
                        WAIT, stop)
        self._say(f'robot and master up: {ok}')
        return [('robot and master publish their FK poses', ok)]

    def teleop_session(self, stop: threading.Event, handle_step, what: str) -> list[Check]:
        """Hold the deadman, move the master handle by ``handle_step`` (3,) [m] in the master's
        frame, check that ring_b followed (scaled) along it, release and check that it holds.
        ``what``: the motion in words."""
        checks = []
        step = np.asarray(handle_step, dtype=float)
        direction = step / np.linalg.norm(step)
        m_pos, m_quat = pose_from_msg(self._get(MASTER_POSE))

        def enable() -> None:
            self._enable.publish(Bool(data=True))

        def handle(position) -> PoseStamped:
            return pose_to_msg(position, m_quat, frame_id=MASTER_FRAME, stamp=self.get_clock().now().to_msg())

        engaged = self._wait(lambda: self._engaged() is True, WAIT, stop, every=enable)
        checks.append(('deadman held: teleop engaged', engaged))
        self._say(f'deadman held, teleop status {self._teleop().code.name}')
        scale = self._teleop().scale
        expected = scale * float(np.linalg.norm(step))
        interrupted = []
        for attempt in range(MOVE_ATTEMPTS):
            # Move the handle while holding the deadman. A clutch in the middle (the mapping
            # disengaged because a stream was late on a busy machine, and re-engaged) loses the
            # master's motion meanwhile; then, like a person, release, bring the handle back
            # (disengaged: the slave stays) and do it again.
            start = self._position(POSE)

            def hold_and_move() -> None:
                enable()
                self._handle.publish(handle(m_pos + step))

            disengaged_before = self._disengagements()[0]

            def followed() -> bool:
                return float((self._position(POSE) - start) @ direction) > 0.8 * expected

            def clutched() -> bool:
                return self._disengagements()[0] > disengaged_before
            ok = self._wait(lambda: followed() or (clutched() and self._engaged() is True), WAIT,
                            stop, every=hold_and_move)
            if not ok and clutched():  # re-engaged after the clutch: whatever follows, follows
                time.sleep(1.0)
            ok = followed()
            moved = float((self._position(POSE) - start) @ direction)
            if ok or attempt == MOVE_ATTEMPTS - 1 or not clutched():
                break
            interrupted.append(self._disengagements()[1])
            self._say(f'the mapping clutched during the motion ({interrupted[-1]}); again')
            self._wait(lambda: self._engaged() is False, WAIT, stop)
            self._wait(lambda: np.linalg.norm(pose_from_msg(self._get(MASTER_POSE))[0] - m_pos) < 2e-4, WAIT,
                       stop, every=lambda: self._handle.publish(handle(m_pos)))
            self._wait(lambda: self._engaged() is True, WAIT, stop, every=enable)
        again = f' (again after {len(interrupted)} clutch(es): {", ".join(interrupted)})' if interrupted else ''
        master = float(np.linalg.norm(step))
        checks.append((f'slave followed the master: moved {moved * 1e3:.1f} mm {what} '
                       f'(master {master * 1e3:.1f} mm x scale {scale:g}){again}', ok))
        self._say(f'master handle {master * 1e3:.1f} mm -> slave {moved * 1e3:.1f} mm {what}')
        # Release the deadman: the mapping disengages and the robot holds.
        released = self._wait(lambda: self._engaged() is False, WAIT, stop)
        since = time.monotonic()

        def still() -> bool:   # moved less than 0.1 mm/s over 0.2 s of the robot's states (not of a
            before = self._get(POSE)   # stalled pose stream: their stamps 0.15 s apart at least)
            time.sleep(0.2)
            after = self._get(POSE)
            return (stamp_to_seconds(after.header.stamp) - stamp_to_seconds(before.header.stamp) >= 0.15
                    and float(np.linalg.norm(pose_from_msg(after)[0] - pose_from_msg(before)[0])) < 2e-5)
        stopped = self._wait(still, STOP_WAIT, stop)   # the legs' jerk-limited stop
        took = time.monotonic() - since
        held_at = self._position(POSE)
        time.sleep(0.5)
        drift = float(np.linalg.norm(self._position(POSE) - held_at))
        code = self._teleop().code.name
        checks.append((f'deadman released: disengaged ({code}), the robot stopped within {took:.1f} s and '
                       f'holds (drift {drift * 1e3:.2f} mm)', released and stopped and drift < 1e-3))
        self._say(f'deadman released, teleop status {code!r}, drift {drift * 1e3:.2f} mm in 0.5 s')
        return checks

    def climb_step(self, stop: threading.Event) -> tuple[list[Check], ClimbStatus | None]:
        """Request one climbing step up (again after a refusal, :data:`STEP_REQUESTS` times in
        all), wait for its preview (up to :data:`PREVIEW_WAIT`) and its execution, resuming a pause
        at most :data:`MAX_RESUMES` times. Returns the checks and the climb status the step ended in
        (None: it did not start)."""
        if not self._wait(self._step.ready, WAIT, stop):
            return [(f'{self._step.name} available', False)], None
        refusals = []
        for _ in range(STEP_REQUESTS):   # a refusal may pass (a state late on a busy machine): ask again
            answer: dict = {}
            self._step.request(+1, lambda ok, text, answer=answer: answer.update(ok=ok, text=text))
            accepted = self._wait(lambda: 'ok' in answer, PREVIEW_WAIT, stop) and answer['ok']
            self._say(f'{self._step.name} -> {answer.get("text", "no answer")!r}'
                      + ('' if 'ok' in answer else f' within {PREVIEW_WAIT:.0f} s; {self._climb_account()}'))
            if accepted or 'ok' not in answer or stop.wait(STEP_RETRY):
                break
            refusals.append(answer['text'])
        again = f' after {len(refusals)} refusal(s): {"; ".join(refusals)}' if refusals and accepted else ''
        checks = [(f'climb step up accepted{again}', accepted)]
        if not accepted:
            return checks, None

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
            return checks + [('climb step started after its preview', False)], None
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
        if self._step.result is not None:   # the action's goal succeeded too
            succeeded = self._wait(self._step.result.done, WAIT, stop) and self._step.result.result().result.success
            checks.append(('climb/step action succeeded', bool(succeeded)))
        return checks, final

    def _resume_climb(self, stop: threading.Event) -> bool:
        """Call ``climb/resume`` until the step accepts it (it refuses while the cause lasts);
        True once it executes again. Says the refusals' reasons when it gives up."""
        refusals: Counter[str] = Counter()   # reason (the reply without its ages): count
        last: list[str] = []

        def accepted() -> bool:
            future = self._resume.call_async(Trigger.Request())
            if not self._wait(future.done, WAIT, stop):
                refusals['no answer'] += 1
                return False
            reply = future.result()
            if reply is not None and not reply.success:
                reason = reply.message.split(' (')[0]
                refusals[reason] += 1
                last[:] = [reply.message]
            return bool(reply is not None and reply.success)
        if not (self._resume.wait_for_service(timeout_sec=WAIT) and self._wait(accepted, WAIT, stop)):
            self._say(f'climb/resume not accepted within {WAIT:.0f} s: '
                      + ('; '.join(f'{n} x {text!r}' for text, n in refusals.items()) or 'no service')
                      + (f'; the last: {last[0]!r}' if last else ''))
            return False
        status = self._climb_state  # the step says it executes again (its status after the resume)
        return self._wait(lambda: status() is not None and status().state is not ClimbState.PAUSED, WAIT, stop)
