"""One phase of a climbing step as it executes (§3, the inchworm gait), pure Python.

A :class:`PhaseRun` goes through ``stream`` (the timed path, one target per tick), ``arrive`` (held
within tolerance for ``settle_time``), ``gripper`` (opens only with the other closed and the
operator heard since settling: the interlock and release gate) and ``done``. A timeout, a refused
gripper or the interlock is a failure, returned as text. A stream paused mid-path brakes along
it to rest (:meth:`PhaseRun.brake`, :mod:`.path_brake`).
"""

from __future__ import annotations

import math

from rrps_climbing.climb_watch import InputWatch
from rrps_climbing.path_brake import PathBrake
from rrps_climbing.phase_path import PhasePath, PlayClock
from rrps_climbing.plan import Phase
from rrps_climbing.step_io import ClimbOutput, ClimbTarget, GripperRequest, StepConfig
from rrps_climbing.timing import TimedMotion
from rrps_description.pose import Pose, pose_error
from rrps_interfaces.climb import PhaseAction

__all__ = ['PhaseRun', 'arrived']


def arrived(pose: Pose | None, T: Pose, config: StepConfig) -> bool:
    """Whether the measured ``pose`` is within the tolerances of ``config`` of ``T``."""
    if pose is None:
        return False
    dp, da = pose_error(pose, T)
    return dp <= config.position_tolerance and da <= config.orientation_tolerance


class PhaseRun:
    """The stages of phase ``phase`` entered at time ``now`` [s] (see the module docstring)."""

    def __init__(self, phase: Phase, config: StepConfig, now: float):
        self.phase, self.config = phase, config
        self.clock = PlayClock(config.period)
        self.request: GripperRequest | None = None
        self.answer: tuple[bool, str] | None = None
        self.arrived_since: float | None = None
        self.settled = 0.0  # watch time when the robot settled at a gripper phase's pose
        self.deadline = now + config.settle_timeout
        self.path: PhasePath | None = None
        if isinstance(phase.timing, TimedMotion):
            self.path = phase.timing.phase_path(config.period)
            self.stage = 'stream'
        else:
            self.stage = 'arrive'

    def on_answer(self, request: GripperRequest, success: bool, message: str) -> None:
        """The driver's answer to ``request`` (one to another request is ignored)."""
        if request is self.request:
            self.answer = (bool(success), message)

    def brake(self) -> bool:
        """A pause: a streaming phase slows along its path to rest within its legs' stream limits
        (:meth:`brake_step` plays it); whether it brakes."""
        if self.stage != 'stream':
            return False
        self.clock.brake(PathBrake(self.phase.timing.leg_limits))
        return self.clock.braking

    def brake_step(self, now: float, out: ClimbOutput) -> None:
        """While a brake is under way: the target of its tick at ``now`` [s] (none after it)."""
        if self.stage == 'stream' and self.clock.braking:
            out.target = ClimbTarget(*self.path.at(self.clock.advance(now)))

    def restart(self, now: float, at: float | None = None) -> None:
        """Go on after a pause at time ``now`` [s]: the path's clock restarts (from path time ``at``
        [s] if given), the deadline anew."""
        self.deadline = now + self.config.settle_timeout
        self.clock.restart(at)

    def played_nearest(self, pose: Pose) -> tuple[float, float, float]:
        """(the time [s] of the streamed path's sample nearest ``pose`` among those played so far,
        its position [m] and orientation [rad] errors): a robot stopped by a fault stands behind
        the stream, which ran on until the pause was known."""
        c = self.config
        t = self.path.nearest(pose, self.clock.t, c.position_tolerance, c.orientation_tolerance)
        return (t, *pose_error(pose, self.path.at(t)[0]))

    def advance(self, now: float, pose: Pose | None, grippers: dict[str, bool], watch: InputWatch,
                out: ClimbOutput) -> str:
        """Run the stages at time ``now`` [s], writing the target and gripper request to ``out``;
        the failure's text ('' while none)."""
        stages = {'stream': self._stream, 'arrive': self._arrive, 'gripper': self._switch_gripper}
        while self.stage in stages:
            passed, failure = stages[self.stage](now, pose, grippers, watch, out)
            if failure or not passed:
                return failure
        return ''

    # Each stage returns (passed on to the next stage within this tick, failure text).

    def _stream(self, now, pose, grippers, watch, out) -> tuple[bool, str]:
        """Send the next sample of the phase's path; at its end, wait for the pose to arrive."""
        t = self.clock.advance(now)
        out.target = ClimbTarget(*self.path.at(t))
        if t >= self.path.duration:
            self.stage = 'arrive'
            self.deadline = now + self.config.settle_timeout
        return False, ''

    def _arrive(self, now, pose, grippers, watch, out) -> tuple[bool, str]:
        """Hold the phase's end pose until the measured pose stayed there ``settle_time``."""
        ph = self.phase
        out.target = ClimbTarget(ph.a_T_b, ph.ring_angles[-1])  # keeps the command stream fresh
        if not arrived(pose, ph.a_T_b, self.config):
            self.arrived_since = None
        elif self.arrived_since is None:
            self.arrived_since = now
        if self.arrived_since is not None and now - self.arrived_since >= self.config.settle_time:
            self.stage = 'gripper' if ph.action in (PhaseAction.RELEASE, PhaseAction.GRIP) else 'done'
            self.deadline = now + self.config.settle_timeout
            self.settled = watch.now()
            return True, ''
        if now > self.deadline:
            dp, da = pose_error(pose, ph.a_T_b) if pose is not None else (math.inf, math.inf)
            return False, (f'step {ph.step}, phase {ph.phase}: the pose did not arrive within '
                           f'{self.config.settle_timeout:.1f} s (error {dp * 1000:.1f} mm, '
                           f'{math.degrees(da):.2f} deg)')
        return False, ''

    def _switch_gripper(self, now, pose, grippers, watch, out) -> tuple[bool, str]:
        """Request the phase's gripper switch (a ring opens only while the other is closed, and
        only once the operator station was heard since the robot settled) and wait until the
        gripper state shows it switched."""
        ph = self.phase
        out.target = ClimbTarget(ph.a_T_b, ph.ring_angles[-1])
        ring, close = ph.ring, ph.action is PhaseAction.GRIP
        if self.request is None:
            other = 'ring_b' if ring == 'ring_a' else 'ring_a'
            if not close and not grippers[other]:
                return False, f'step {ph.step}, phase {ph.phase}: interlock: {other} is not closed'
            if close or watch.operator_heard_since(self.settled):
                self.request = out.gripper = GripperRequest(ring, close)
        elif self.answer is not None:
            success, message = self.answer
            if not success:
                return False, f'step {ph.step}, phase {ph.phase}: {ring} gripper refused: {message}'
            if grippers[ring] == close:
                self.stage = 'done'
                return True, ''
        if now > self.deadline:
            return False, (f'step {ph.step}, phase {ph.phase}: {ring} gripper did not switch within '
                           f'{self.config.settle_timeout:.1f} s')
        return False, ''
