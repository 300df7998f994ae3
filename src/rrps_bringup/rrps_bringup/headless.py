"""The scripted operator of ``rrps-demo --headless``: a teleop session and a climb, no browser.

It uses the same topics and services as a person at the viewer: ``master/target_pose`` (the
handle), ``teleop/enable`` (the deadman, 20 Hz while held), ``climb/step_up``, ``climb/resume``;
it checks the robot's answer on ``pose``, ``teleop/status``, ``climb/status`` and ``odometry/*``.

Like a person, it resumes a climbing step that paused (the robot's state or the operator link
was late: the step holds, see ``PauseReason``) once the step accepts the resume, at most
:data:`MAX_RESUMES` times, and says so: on a machine too busy to keep the state fresh the
summary shows the pauses rather than hiding them.
"""

from __future__ import annotations

import threading
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from rrps_interfaces.climb import CLIMB_RESUME, CLIMB_STATUS, CLIMB_STEP_UP, ClimbState, ClimbStatus, odometry_topic
from rrps_interfaces.kinematics import POSE
from rrps_interfaces.teleop import (
    MASTER_FRAME,
    MASTER_POSE,
    MASTER_TARGET_POSE,
    TELEOP_ENABLE,
    TELEOP_STATUS,
    TeleopStatus,
)
from rrps_runtime.messages import pose_from_msg, pose_to_msg
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS

#: Master handle displacement of the scripted session [m] (the slave moves translation_scale x).
HANDLE_STEP = 0.004
#: Most resumes of a paused climbing step the scripted operator makes.
MAX_RESUMES = 5
#: Deadline [s] of each thing the script waits for (it ends as soon as it happened): generous,
#: so that a machine slowed by other jobs delays the session rather than failing it.
WAIT = 30.0
#: longest wait [s] for a requested climbing step to start: its preview runs first
PREVIEW_WAIT = 120.0


class DemoScript(Node):
    """Plays the operator; :meth:`run` returns True when every check passed."""

    def __init__(self, **kwargs):
        super().__init__('demo_script', **kwargs)
        self._lock = threading.Lock()
        self._latest: dict[str, object] = {}
        self._disengaged: tuple[int, str] = (0, '')
        for topic in (POSE, MASTER_POSE, odometry_topic('ring_a'), odometry_topic('ring_b')):
            self.create_subscription(PoseStamped, topic,
                                     lambda m, topic=topic: self._store(topic, m), STATE_QOS)
        for topic in (TELEOP_STATUS, CLIMB_STATUS):
            self.create_subscription(DiagnosticStatus, topic,
                                     lambda m, topic=topic: self._store(topic, m), STATE_QOS)
        self._enable = self.create_publisher(Bool, TELEOP_ENABLE, COMMAND_QOS)
        self._handle = self.create_publisher(PoseStamped, MASTER_TARGET_POSE, COMMAND_QOS)
        self._step_up = self.create_client(Trigger, CLIMB_STEP_UP)
        self._resume = self.create_client(Trigger, CLIMB_RESUME)

    def _store(self, topic: str, msg) -> None:
        with self._lock:
            self._latest[topic] = msg
            if topic == TELEOP_STATUS:
                # Every disengagement counts, also one shorter than the script's polling period.
                status = TeleopStatus.from_key_values(msg.values)
                if not status.engaged:
                    self._disengaged = (self._disengaged[0] + 1, status.code.name)

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

    @staticmethod
    def _say(text: str) -> None:
        print(f'rrps demo --headless: {text}', flush=True)

    def run(self, stop: threading.Event, *, viewer=None) -> bool:
        """The scripted session; prints each step and returns overall success."""
        checks: list[tuple[str, bool]] = []
        ok = self._wait(lambda: self._get(POSE) is not None and self._get(MASTER_POSE) is not None,
                        WAIT, stop)
        checks.append(('robot and master publish their FK poses', ok))
        self._say(f'robot and master up: {ok}')
        if ok:
            checks += self._teleop_session(stop)
        if not stop.is_set():
            checks += self._climb(stop)
        if viewer is not None:
            drawn = viewer.viewer.frames_drawn
            checks.append((f'viewer drew {drawn} frames at {viewer.url}', drawn > 0))
        self._say('summary:')
        for text, passed in checks:
            print(f'  [{"PASS" if passed else "FAIL"}] {text}', flush=True)
        return bool(checks) and all(passed for _, passed in checks)

    def _engaged(self) -> bool | None:
        status = self._teleop()
        return None if status is None else status.engaged

    def _teleop_session(self, stop: threading.Event) -> list[tuple[str, bool]]:
        checks = []
        m_pos, m_quat = pose_from_msg(self._get(MASTER_POSE))

        def enable() -> None:
            self._enable.publish(Bool(data=True))

        def handle(position) -> PoseStamped:
            return pose_to_msg(position, m_quat, frame_id=MASTER_FRAME, stamp=self.get_clock().now().to_msg())

        engaged = self._wait(lambda: self._engaged() is True, WAIT, stop, every=enable)
        checks.append(('deadman held: teleop engaged', engaged))
        self._say(f'deadman held, teleop status {self._teleop().code.name}')
        scale = self._teleop().scale
        expected = scale * HANDLE_STEP
        interrupted = []
        for attempt in range(2):
            # Move the handle up while holding the deadman. A clutch in the middle (the mapping
            # disengaged because a stream was late on a busy machine, and re-engaged) loses the
            # master's motion meanwhile; then, like a person, release, bring the handle back
            # (disengaged: the slave stays) and do it again.
            start = self._position(POSE)

            def hold_and_move() -> None:
                enable()
                self._handle.publish(handle(m_pos + [0.0, 0.0, HANDLE_STEP]))

            disengaged_before = self._disengagements()[0]

            def followed() -> bool:
                return self._position(POSE)[2] - start[2] > 0.8 * expected

            def clutched() -> bool:
                return self._disengagements()[0] > disengaged_before
            ok = self._wait(lambda: followed() or (clutched() and self._engaged() is True), WAIT,
                            stop, every=hold_and_move)
            if not ok and clutched():  # re-engaged after the clutch: whatever follows, follows
                time.sleep(1.0)
            ok = followed()
            moved = self._position(POSE) - start
            if ok or attempt == 1 or not clutched():
                break
            interrupted.append(self._disengagements()[1])
            self._say(f'the mapping clutched during the motion ({interrupted[-1]}); again')
            self._wait(lambda: self._engaged() is False, WAIT, stop)
            self._wait(lambda: abs(pose_from_msg(self._get(MASTER_POSE))[0][2] - m_pos[2]) < 2e-4, WAIT, stop,
                       every=lambda: self._handle.publish(handle(m_pos)))
            self._wait(lambda: self._engaged() is True, WAIT, stop, every=enable)
        again = f' (again after a clutch: {interrupted[0]})' if interrupted else ''
        checks.append((f'slave followed the master: moved {moved[2] * 1e3:.1f} mm up '
                       f'(master {HANDLE_STEP * 1e3:.1f} mm x scale {scale:g}){again}', ok))
        self._say(f'master handle up {HANDLE_STEP * 1e3:.1f} mm -> slave up {moved[2] * 1e3:.1f} mm')
        # Release the deadman: the mapping disengages and the robot holds.
        released = self._wait(lambda: self._engaged() is False, WAIT, stop)
        held_at = self._position(POSE)
        time.sleep(0.5)
        drift = float(np.linalg.norm(self._position(POSE) - held_at))
        code = self._teleop().code.name
        checks.append((f'deadman released: disengaged ({code}) and '
                       f'the robot holds (drift {drift * 1e3:.2f} mm)', released and drift < 1e-3))
        self._say(f'deadman released, teleop status {code!r}, drift {drift * 1e3:.2f} mm in 0.5 s')
        return checks

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
