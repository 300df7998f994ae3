"""The climbing step's state machine (§3, the inchworm gait), pure Python.

A request's plan is computed by the caller (``ClimbOutput.plan``, :func:`.step_plan.plan_step`)
and handed back (:meth:`ClimbStepMachine.on_plan`); the climb then runs phase by phase
(:class:`.phase_run.PhaseRun`), once per tick. With ``preview`` a step is first simulated (the
caller runs ``ClimbOutput.preview``). A plan or a preview starts only if accepted and nothing
changed meanwhile, else a :class:`~rrps_interfaces.climb.StepRefusal`. A lost input pauses it (a
motion brakes along its path first) until :meth:`ClimbStepMachine.resume`; a failure is final.
Each call takes plain values and returns a :class:`ClimbOutput`. No ROS import.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable

from rrps_climbing.climb_inputs import ClimbInputs
from rrps_climbing.gait import GaitPlanner
from rrps_climbing.phase_run import PhaseRun
from rrps_climbing.plan import Phase
from rrps_climbing.step_io import ClimbOutput, GripperRequest, PlanRequest, StepConfig, StepPlan
from rrps_climbing.step_preview import StepSnapshot
from rrps_description.pose import Pose
from rrps_interfaces.climb import (
    CLIMB_RESUME,
    ClimbPreview,
    ClimbState,
    ClimbStatus,
    PauseReason,
    StepRefusal,
)
from rrps_kinematics.odometry import RingOdometry

__all__ = ['ClimbStepMachine']

IDLE, EXECUTING, PAUSED, FAILED = (ClimbState.IDLE, ClimbState.EXECUTING, ClimbState.PAUSED,
                                   ClimbState.FAILED)

#: How far off the paused path [tolerances] the robot may be for a resume mid-motion.
RESUME_TOLERANCE_FACTOR = 10.0


class ClimbStepMachine(ClimbInputs):
    """Executes climbs of ``planner``'s robot on its structure (see the module docstring).
    ``start`` [m]: ring_a's gripper on the route (None: the lowest that fits); ``clock``: the input
    watch's receipt clock [s]."""

    def __init__(self, planner: GaitPlanner, config: StepConfig | None = None, *,
                 start: float | None = None, step_length: float | None = None, auto_steps: int = 0,
                 clock: Callable[[], float] = time.monotonic, preview: bool = False):
        self.planner = planner
        self.config = config or StepConfig()
        super().__init__(self.config, clock)
        self.structure = planner.structure
        self.step_length = float(step_length or planner.default_step)
        if not (math.isfinite(self.step_length) and self.step_length > 0.0):
            raise ValueError(f'step_length must be finite and > 0, got {step_length!r}')
        if isinstance(auto_steps, bool) or int(auto_steps) != auto_steps or auto_steps < 0:
            raise ValueError(f'auto_steps must be a non-negative integer, got {auto_steps!r}')
        self.auto_steps = int(auto_steps)
        sep = planner.sep_home
        s_a = max(0.0, -sep) if start is None else float(start)
        if not (0.0 <= s_a and s_a + sep <= self.structure.length):
            raise ValueError(f'start {s_a} m: the robot does not fit on the {self.structure.name} '
                             f'(route 0 .. {self.structure.length:.3f} m)')
        #: route positions [m] of the rings' grippers and their extra-DOF angle [rad] at rest
        self.s_a, self.s_b, self.theta = s_a, s_a + sep, 0.0
        self.mode = IDLE
        self.pause_reason: PauseReason | None = None
        self.detail = 'waiting for pose and grippers/state'
        self.plan_refused = False
        self.refusal: StepRefusal | None = None
        self.preview = bool(preview)
        self._planning: StepSnapshot | None = None  # the inputs when the plan being made was asked for
        self._pending: tuple[list[Phase], str, StepSnapshot] | None = None  # being previewed
        self.steps_done = 0
        self.timing = (math.nan, math.nan)  # the last planned step's duration [s] and climbing speed [m/min]
        self.plan_duration = math.nan  # the executing (or last executed) climb's planned duration [s]
        self.odometry: RingOdometry | None = None
        self._phases: list[Phase] = []
        self._index = 0
        self._run: PhaseRun | None = None  # the executing phase's stages
        self._auto_started = False
        self._scripted = False  # the plan being made is the scripted climb's
        self._last_status = None
        self._out = ClimbOutput()

    # --- inputs ---------------------------------------------------------------------------------

    def on_pose(self, pose: Pose) -> ClimbOutput:
        """Use the newest measured pose a_T_b: chain the odometry (fails the climb when the
        gripper states show both grippers open)."""
        out = self._begin()
        self.pose = pose
        if self.grippers is None:
            return out
        ma, mb = self.planner.mounts(*self.thetas())
        if self.odometry is None:
            world_T_a = self.planner.world_rings(self.s_a, self.s_b, self.theta, self.theta)[0]
            self.odometry = RingOdometry(world_T_a, pose, a_T_grip=ma, b_T_grip=mb)
        elif self.grippers['ring_a'] or self.grippers['ring_b']:
            self.odometry.update(pose, self.grippers['ring_a'], self.grippers['ring_b'],
                                 a_T_grip=ma, b_T_grip=mb)
        else:
            self._fail('interlock: grippers/state shows both grippers open')
            return out
        out.odometry = (self.odometry.world_T_a, self.odometry.world_T_b)
        return out

    def on_gripper_answer(self, request: GripperRequest, success: bool, message: str = '') -> None:
        """The driver's answer to ``request`` (used at the next tick; an answer to another request
        than the pending one is ignored)."""
        if self._run is not None:
            self._run.on_answer(request, success, message)

    def thetas(self) -> tuple[float, float]:
        """The rings' extra-DOF angles (theta_a, theta_b) [rad]: measured where the robot has the
        DOF, else those of the plan."""
        if self.measured_angles is not None:
            return float(self.measured_angles[0]), float(self.measured_angles[1])
        if self.mode is EXECUTING and self._phases:
            ph = self._phases[min(self._index, len(self._phases) - 1)]
            return ph.theta_a, ph.theta_b
        return self.theta, self.theta

    # --- requests -------------------------------------------------------------------------------

    def step(self, direction: int, now: float) -> ClimbOutput:
        """Ask for one step up (``direction`` +1) or down (-1) at time ``now`` [s]."""
        return self.start_climb(direction * self.step_length, 1, now)

    def plan_request(self, distance: float, steps: int) -> PlanRequest:
        """The plan of a climb of ``distance`` [m] in ``steps`` from where the rings rest now."""
        return PlanRequest(distance, steps, self.s_a, self.s_b - self.s_a, self.theta, self.pose, self.config)

    def start_climb(self, distance: float, steps: int, now: float) -> ClimbOutput:
        """Ask for a climb of ``distance`` [m] in ``steps``: refused at once (the reply says why),
        or its plan asked for (``out.plan``; the reply then comes from :meth:`on_plan`)."""
        out = self._begin()
        refusal = self._start_refusal()
        if refusal:
            out.reply = (False, f'refused: {refusal}')
            return out
        out.plan = self.plan_request(distance, steps)
        self._planning = self.snapshot()
        self.detail = f'planning a climb of {distance:+.3f} m in {steps} step(s)'
        self._report(force=True)
        out.reply = (True, self.detail)
        return out

    def on_plan(self, plan: StepPlan, now: float) -> ClimbOutput:
        """The plan asked for, at time ``now`` [s]: previewed or started if nothing changed
        meanwhile, else refused (logged, in the status); the reply is the request's."""
        out = self._answer_plan(plan, now)
        if self._scripted:
            self._scripted = False
            out.log.append((logging.INFO, f'scripted climb of {self.auto_steps} steps: {out.reply[1]}'))
        return out

    def _answer_plan(self, plan: StepPlan, now: float) -> ClimbOutput:
        out = self._begin()
        snapshot, self._planning = self._planning, None
        if snapshot is None:
            out.reply = (False, 'refused: the climb was cancelled while it was planned')
            return out
        changed = None if plan.refusal else self.changed_since(snapshot, self.config)
        if plan.refusal or changed:
            kind, why = (StepRefusal.PLAN, plan.refusal) if plan.refusal else changed
            self._refuse(kind, f'{"plan" if plan.refusal else "step"} refused: {why}')
            out.reply = (False, f'refused: {why}')
            return out
        phases = list(plan.phases)
        self.timing, self.plan_refused, self.refusal = plan.timing, False, None
        if self.preview:
            self._pending = (phases, plan.detail, snapshot)
            self.detail = f'previewing {plan.detail}'
            out.preview = phases
            self._report(force=True)
            out.reply = (True, self.detail)
            return out
        self._execute(phases, plan.detail, now)
        out.reply = (True, f'started: {self.detail}')
        return out

    def on_preview(self, preview: ClimbPreview, now: float) -> ClimbOutput:
        """The preview of the step being previewed, at time ``now`` [s]: start it if the preview
        accepts it and nothing changed meanwhile, else refuse it (logged, in the status)."""
        out = self._begin()
        if self._pending is None:
            return out
        phases, detail, snapshot = self._pending
        self._pending = None
        if not preview.accepted:
            kind = StepRefusal.PREVIEW_LIMIT if preview.limit is not None else StepRefusal.PREVIEW_FAILED
            self._refuse(kind, f'preview refused the step: {preview.detail}')
            return out
        changed = self.changed_since(snapshot, self.config)
        if changed is not None:
            self._refuse(changed[0], f'step refused: {changed[1]}')
            return out
        self._execute(phases, detail, now)
        out.log.append((logging.INFO, f'started: {self.detail} (preview: {preview.detail})'))
        return out

    def _execute(self, phases: list[Phase], detail: str, now: float) -> None:
        self._phases, self._index = phases, 0
        self.plan_duration = float(sum(ph.duration for ph in phases))
        self._enter_phase(now)
        self.mode = EXECUTING
        self.detail = detail
        self._report(force=True)

    def resume(self, now: float) -> ClimbOutput:
        """Resume a paused step at time ``now`` [s] once the cause of the pause is gone and the
        robot is still on the paused path; a motion goes on from the point of its path where the robot
        stands (:meth:`.PhaseRun.played_nearest`), braked or not."""
        out = self._begin()
        if self.mode is not PAUSED:
            out.reply = (False, f'refused: the climb is {self.mode.value}')
            return out
        reason = self.hold_reason()
        if reason is not None:
            out.reply = (False, f'refused: {reason.value} ({self.watch.ages()})')
            return out
        at = None
        if self._run.stage == 'stream':   # on from the path's point where the robot stands
            at, dp, da = self._run.played_nearest(self.pose)
            if (dp > RESUME_TOLERANCE_FACTOR * self.config.position_tolerance
                    or da > RESUME_TOLERANCE_FACTOR * self.config.orientation_tolerance):
                out.reply = (False, f'refused: the robot is {dp * 1e3:.1f} mm / {math.degrees(da):.2f} '
                             'deg off the paused path')
                return out
        self._run.restart(now, at)
        self.mode, self.pause_reason = EXECUTING, None
        ph = self._phases[self._index]
        self.detail = f'resumed at step {ph.step}, phase {ph.phase}'
        self._report(force=True)
        out.reply = (True, self.detail)
        return out

    def cancel(self) -> ClimbOutput:
        """Hold the executing step as a pause (the action's cancel); a step being planned or previewed
        never starts."""
        out = self._begin()
        self._planning = self._pending = None
        if self.mode is EXECUTING:
            self._pause(PauseReason.CANCELLED)
        out.reply = (True, self.detail)
        return out

    def tick(self, now: float) -> ClimbOutput:
        """One period at time ``now`` [s]: start the scripted climb, pause on a lost input, or
        advance the executing phase."""
        self.watch.tick_started()
        try:
            return self._tick(now)
        finally:
            self.watch.tick_ended()

    # --- status ---------------------------------------------------------------------------------

    def status(self) -> ClimbStatus:
        """The climb's status now."""
        ph = self._phases[self._index] if self.mode in (EXECUTING, PAUSED) and self._phases else None
        return ClimbStatus(state=self.mode, pause_reason=self.pause_reason,
                           step=ph.step if ph else self.steps_done,
                           action=ph.action if ph else None, ring=ph.ring if ph else '', phase_index=self._index,
                           structure=self.structure.name, s_a=self.s_a, s_b=self.s_b, phases=len(self._phases),
                           steps_done=self.steps_done, detail=self.detail,
                           previewing=self._pending is not None or self._planning is not None,
                           refusal=self.refusal,
                           step_duration=self.timing[0], climbing_speed=self.timing[1],
                           plan_duration=self.plan_duration)

    @property
    def planning(self) -> bool:
        """Whether the plan of a request is being made (asked for, not yet handed back)."""
        return self._planning is not None

    def report(self) -> ClimbStatus:
        """The status to report periodically (what changes after it is reported again at once)."""
        status = self.status()
        self._last_status = self._status_key(status)
        return status

    # --- internals ------------------------------------------------------------------------------

    def _begin(self) -> ClimbOutput:
        self._out = ClimbOutput()
        return self._out

    @staticmethod
    def _status_key(status: ClimbStatus) -> tuple:
        return (status.state, status.pause_reason, status.action, status.ring, status.step,
                status.previewing, status.refusal)

    def _report(self, force: bool = False) -> None:
        """Report the status now when forced or when the state or phase changed."""
        status = self.status()
        key = self._status_key(status)
        if force or key != self._last_status:
            self._last_status = key
            self._out.status = status

    def _start_refusal(self) -> str:
        """Why a climb cannot start now ('' when it can)."""
        if self.mode is EXECUTING:
            return 'a climb is executing'
        if self._planning is not None:
            return 'a step is being planned'
        if self._pending is not None:
            return 'a step is being previewed'
        if self.mode is PAUSED:
            return f'a climb is paused ({self.pause_reason.value}): resume it'
        if self.mode is FAILED:
            return f'climb_node is in error ({self.detail})'
        if self.teleop_engaged:
            return 'teleoperation is engaged'
        if self.pose is None or self.grippers is None:
            return 'no pose or grippers/state received yet'
        reason = self.hold_reason()
        if reason is not None:
            return f'{reason.value} ({self.watch.ages()})'
        return ''

    def _refuse(self, refusal: StepRefusal, detail: str) -> None:
        self.detail, self.plan_refused, self.refusal = detail, True, refusal
        self._out.log.append((logging.WARNING, detail))
        self._report(force=True)

    def _pause(self, reason: PauseReason) -> None:
        """Hold: a motion brakes along its path (not for an inactive driver, which holds the legs
        itself), then no target and no gripper request until :meth:`resume`."""
        ph = self._phases[self._index]
        self.mode, self.pause_reason = PAUSED, reason
        braking = reason is not PauseReason.DRIVER_INACTIVE and self._run.brake()
        self.detail = (f'paused at step {ph.step}, phase {ph.phase}: {reason.value} ({self.watch.ages()}); '
                       f'{"braking along the path, then " if braking else ""}holding, grippers as they are; '
                       f'{CLIMB_RESUME} resumes')
        self._out.log.append((logging.ERROR, self.detail))
        self._report(force=True)

    def _fail(self, reason: str) -> None:
        self.mode = FAILED
        self.detail = reason
        self._out.log.append((logging.ERROR, reason))
        self._report(force=True)

    def _tick(self, now: float) -> ClimbOutput:
        out = self._begin()
        if self.mode is IDLE and self.auto_steps > 0 and not self._auto_started \
                and self.pose is not None and self.grippers is not None:
            self._auto_started = True
            started = self.start_climb(self.auto_steps * self.step_length, self.auto_steps, now)
            self._scripted = started.plan is not None
            if not self._scripted:
                started.log.append((logging.INFO, f'scripted climb of {self.auto_steps} steps: {started.reply[1]}'))
            return started
        if self.mode is PAUSED:
            self._run.brake_step(now, out)
        if self.mode is not EXECUTING:
            return out
        reason = self.hold_reason() if self.watch.judged() else None
        if reason is not None:
            self._pause(reason)
            return out
        failure = self._run.advance(now, self.pose, self.grippers, self.watch, self._out)
        if failure:
            self._fail(failure)
        elif self._run.stage == 'done':
            self._next_phase(self._phases[self._index], now)
        return out

    def _enter_phase(self, now: float) -> None:
        self._run = PhaseRun(self._phases[self._index], self.config, now)

    def _next_phase(self, ph: Phase, now: float) -> None:
        """The phase is done: on to the next one, or the climb is over (idle)."""
        self.s_a, self.s_b = ph.s_a, ph.s_b
        self._index += 1
        if self._index >= len(self._phases):
            self.theta = ph.theta_a
            self.steps_done += max(p.step for p in self._phases)
            self.mode = IDLE
            self.detail = f'done: ring_a at s={self.s_a:.3f} m, ring_b at s={self.s_b:.3f} m'
            self._phases = []
            self._report(force=True)
            return
        self._enter_phase(now)
        self._report()
