"""The step machine leaves a request's plan to its caller (climb_node makes it in its worker
process, so that no executor waits for tens of milliseconds of Python): what it asks for, what it
does while the plan is made, and what it does with the plan once it comes back, checked against
the planner called directly.
"""

from __future__ import annotations

import pickle
from dataclasses import replace

import pytest

from rrps_climbing.step_io import PlanRequest, StepPlan
from rrps_climbing.step_machine import ClimbStepMachine
from rrps_climbing.step_plan import plan_step
from rrps_interfaces.climb import StepRefusal
from rrps_testing.climb_rig import EXECUTING, IDLE, PLANNER, START, STEP, ClimbRig


class _NoPlanning:
    """The rig's planner, except that planning here fails the test."""

    def __getattr__(self, name):
        if name in ('plan', 'approach'):
            raise AssertionError(f'the machine called planner.{name} itself')
        return getattr(PLANNER, name)


def _rig_without_planning(**kwargs) -> ClimbRig:
    rig = ClimbRig(**kwargs)
    rig.machine.planner = _NoPlanning()
    rig.tick()
    return rig


def test_a_step_request_asks_for_its_plan_and_waits_for_it():
    rig = _rig_without_planning()
    out = rig.machine.step(+1, rig.t)
    assert out.reply == (True, f'planning a climb of +{STEP:.3f} m in 1 step(s)')
    assert out.plan.separation == pytest.approx(PLANNER.sep_home, abs=1e-12)
    assert replace(out.plan, separation=PLANNER.sep_home) == PlanRequest(STEP, 1, START, PLANNER.sep_home, 0.0,
                                                                         rig.pose, rig.machine.config)
    assert out.status.state is IDLE and out.status.previewing and rig.machine.planning
    assert rig.machine.step(-1, rig.t).reply == (False, 'refused: a step is being planned')
    assert rig.tick().target is None      # nothing commanded while the plan is made

    planned = rig.machine.on_plan(plan_step(PLANNER, pickle.loads(pickle.dumps(out.plan))), rig.t)
    expected = PLANNER.plan(STEP, 1, start=START)
    assert planned.reply[0] and planned.reply[1] == f'started: {expected.describe()}'
    assert planned.status.state is EXECUTING and not planned.status.previewing and not rig.machine.planning
    assert rig.machine.plan_duration == pytest.approx(sum(ph.duration for ph in expected.phases))


def test_a_refused_plan_refuses_the_request_and_the_machine_can_plan_again():
    rig = _rig_without_planning()
    out = rig.machine.start_climb(10.0, 1, rig.t)      # 10 m in one step: no leg reaches that far
    refused = plan_step(PLANNER, out.plan)
    assert refused.refusal and not refused.phases
    answer = rig.machine.on_plan(refused, rig.t)
    assert answer.reply == (False, f'refused: {refused.refusal}')
    assert answer.status.refusal is StepRefusal.PLAN and answer.status.detail == f'plan refused: {refused.refusal}'
    assert rig.machine.step(+1, rig.t).plan is not None


def test_inputs_that_change_while_the_plan_is_made_refuse_it():
    rig = _rig_without_planning()
    out = rig.machine.step(+1, rig.t)
    rig.engaged = True                                  # teleoperation engaged meanwhile
    rig.tick()
    answer = rig.machine.on_plan(plan_step(PLANNER, out.plan), rig.t)
    assert not answer.reply[0] and answer.status.refusal is StepRefusal.TELEOP_ENGAGED
    assert rig.machine.status().state is IDLE


def test_a_plan_that_comes_back_after_a_cancel_never_starts():
    rig = _rig_without_planning()
    out = rig.machine.step(+1, rig.t)
    rig.machine.cancel()
    answer = rig.machine.on_plan(plan_step(PLANNER, out.plan), rig.t)
    assert answer.reply == (False, 'refused: the climb was cancelled while it was planned')
    assert rig.machine.status().state is IDLE and rig.machine.steps_done == 0


def test_a_failed_plan_job_is_a_refusal_like_any_other():
    rig = _rig_without_planning()
    rig.machine.step(+1, rig.t)
    answer = rig.machine.on_plan(StepPlan(refusal='plan failed: BrokenProcessPool: the worker died'), rig.t)
    assert answer.reply == (False, 'refused: plan failed: BrokenProcessPool: the worker died')
    assert isinstance(rig.machine, ClimbStepMachine) and rig.machine.status().refusal is StepRefusal.PLAN
