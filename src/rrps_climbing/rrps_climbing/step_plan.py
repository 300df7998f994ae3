"""A climb's plan for the step machine (:class:`.step_io.PlanRequest` in, :class:`.step_io.StepPlan`
out, plain data): tens of milliseconds of Python, made where the caller chooses, climb_node's
worker process or inline. No ROS import.
"""

from __future__ import annotations

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.phase_run import arrived
from rrps_climbing.plan import PlanError
from rrps_climbing.step_io import PlanRequest, StepPlan

__all__ = ['plan_step']


def plan_step(planner: GaitPlanner, request: PlanRequest) -> StepPlan:
    """``planner``'s plan of ``request``, preceded by bringing ring_b back to the gait when the
    measured pose is off its start (after teleoperation); a PlanError or ValueError is the refusal."""
    try:
        plan = planner.plan(request.distance, request.steps, start=request.s_a,
                            initial_separation=request.separation, initial_theta=request.theta)
    except (PlanError, ValueError) as exc:
        return StepPlan(refusal=str(exc))
    phases = list(plan.phases)
    if request.pose is not None and not arrived(request.pose, phases[0].a_T_b, request.config):
        try:
            phases = planner.approach(request.pose, request.s_a, request.s_a + request.separation,
                                      request.theta, request.theta) + phases
        except PlanError as exc:
            return StepPlan(refusal=f'cannot bring ring_b back to the gait: {exc}')
    return StepPlan(tuple(phases), plan.describe(), plan.step_timing)
