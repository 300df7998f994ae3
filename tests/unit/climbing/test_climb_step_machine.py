"""ClimbStepMachine without ROS: a whole step, the interlock, failures and refusals, the preview
before a step starts, and what the machine outputs at each point, in the simulated system of
:class:`rrps_testing.climb_rig.ClimbRig` (its docstring says what it stands for). Pauses and
resumes: test_climb_step_pauses.py.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from rrps_climbing.step_io import GripperRequest, StepConfig
from rrps_climbing.step_machine import ClimbStepMachine
from rrps_description.pose import Pose, pose_error
from rrps_interfaces.climb import ClimbPreview, PauseReason, PhaseAction, PreviewLimit, StepRefusal
from rrps_testing.climb_rig import (
    DT,
    EXECUTING,
    FAILED,
    HOME,
    IDLE,
    PAUSED,
    PLANNER,
    START,
    STEP,
    ClimbRig,
    assert_brakes,
    in_phase,
    started,
)


def test_a_whole_step_goes_through_every_phase_and_ends_where_the_plan_says():
    rig = ClimbRig()
    rig.tick()
    assert rig.outputs[-1][1].target is None                # idle: nothing commanded
    out = rig.call(rig.machine.step, +1)
    assert out.reply[0] and out.reply[1].startswith('started: 1 step(s) of 0.060 m')
    assert out.status.state is EXECUTING and out.status.phase == 'start'
    rig.run_until(lambda s: s.state is IDLE)

    plan = PLANNER.plan(STEP, 1, start=START)
    seen = [s.phase for _, s in rig.statuses() if s.state is EXECUTING]
    assert seen == [ph.phase for ph in plan.phases]         # every phase, in order, reported once
    assert seen[-6:] == ['release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a']
    requests = [(r.ring, r.close) for _, r in rig.requests()]
    assert requests[-4:] == [('ring_b', False), ('ring_b', True), ('ring_a', False), ('ring_a', True)]
    assert requests == [(ph.ring, ph.action is PhaseAction.GRIP) for ph in plan.phases
                        if ph.action in (PhaseAction.RELEASE, PhaseAction.GRIP)]
    assert not rig.both_open

    # a gripper is asked to switch only after the pose stayed at the phase's pose settle_time
    entered = {}
    for t, s in rig.statuses():
        entered.setdefault((s.step, s.phase), t)
    for (t, request), (key, t_entry) in zip(rig.requests(), [(k, t) for k, t in entered.items()
                                                            if k[1].startswith(('release', 'grip'))]):
        assert t - t_entry >= 0.1 - 1e-9, key

    # the motions are streamed as timed: no target jumps beyond the path speed over a tick (a
    # translation along the pole), and a motion takes its timing's duration
    targets = [(t, out.target.a_T_b.position) for t, out in rig.outputs if out.target is not None]
    jumps = np.linalg.norm(np.diff([p for _, p in targets], axis=0), axis=1)
    peak = max(ph.timing.peak_speed for ph in plan.phases if ph.timing is not None)
    assert np.max(jumps) <= peak * DT + 1e-9
    move_a = next(ph for ph in plan.phases if ph.phase == 'move_a')
    t_move = entered[(1, 'move_a')]
    t_grip = entered[(1, 'grip_a')]
    assert t_grip - t_move >= move_a.timing.duration - DT

    done = rig.machine.status()
    assert done.steps_done == 1 and done.step == 1 and done.detail.startswith('done')
    assert done.s_a == pytest.approx(START + STEP) and rig.machine.s_a == pytest.approx(START + STEP)
    world_T_a, world_T_b = [out.odometry for _, out in rig.outputs if out.odometry is not None][-1]
    assert world_T_a.position[2] == pytest.approx(START + STEP, abs=1e-9)   # the pole is vertical
    assert np.allclose((world_T_a @ rig.pose).matrix, world_T_b.matrix, atol=1e-9)
    assert pose_error(rig.pose, plan.phases[-1].a_T_b)[0] < 1e-9
    assert all(out.target is None and out.gripper is None for out in [rig.tick() for _ in range(5)])


def test_a_step_down_after_a_step_up_comes_back():
    rig = ClimbRig()
    started(rig, +1)
    rig.run_until(lambda s: s.state is IDLE)
    assert rig.call(rig.machine.step, -1).reply[0]
    rig.run_until(lambda s: s.state is IDLE)
    assert rig.machine.steps_done == 2 and rig.machine.s_a == pytest.approx(START)


def test_a_release_is_refused_while_the_other_ring_is_open():
    rig = ClimbRig()
    started(rig)
    rig.run_until(in_phase('release_b'))
    rig.grippers['ring_a'] = False                   # the driver shows ring_a open
    rig.run_until(lambda s: s.state is not EXECUTING)
    status = rig.machine.status()
    assert status.state is FAILED and status.detail.endswith('interlock: ring_a is not closed')
    assert rig.outputs[-1][1].status.state is FAILED
    assert (logging.ERROR, status.detail) in rig.outputs[-1][1].log
    assert not any(not r.close for _, r in rig.requests())     # no gripper was asked to open
    assert all(out.target is None and out.gripper is None for out in [rig.tick() for _ in range(5)])
    refused = rig.call(rig.machine.step, +1)
    assert not refused.reply[0] and 'in error' in refused.reply[1]


def test_both_grippers_shown_open_fail_the_climb():
    rig = ClimbRig()
    rig.tick()
    rig.grippers = {'ring_a': False, 'ring_b': False}
    rig.tick()
    status = rig.machine.status()
    assert status.state is FAILED and 'both grippers open' in status.detail


def test_a_refused_gripper_fails_the_step_and_the_robot_holds():
    rig = ClimbRig()
    rig.answer = (False, 'jammed')
    started(rig)
    rig.run_until(lambda s: s.state is not EXECUTING)
    status = rig.machine.status()
    assert status.state is FAILED and status.detail == 'step 0, phase release_b: ring_b gripper refused: jammed'
    assert rig.grippers == {'ring_a': True, 'ring_b': True}
    assert all(out.target is None and out.gripper is None for out in [rig.tick() for _ in range(5)])
    assert not rig.call(rig.machine.resume).reply[0]


def test_a_gripper_that_does_not_switch_or_a_pose_that_does_not_arrive_fails_after_settle_timeout():
    rig = ClimbRig(settle_timeout=0.5)
    rig.switch = False
    started(rig)
    rig.run_until(in_phase('release_b'))
    t0 = rig.t
    rig.run_until(lambda s: s.state is not EXECUTING)
    assert 'ring_b gripper did not switch within 0.5 s' in rig.machine.detail
    assert 0.5 + 0.1 <= rig.t - t0 <= 0.5 + 0.1 + 3 * DT   # settle, then the gripper's timeout
    rig = ClimbRig(settle_timeout=0.5)
    rig.track = False
    started(rig)
    rig.run_until(lambda s: s.state is not EXECUTING)
    assert 'phase move_b: the pose did not arrive within 0.5 s' in rig.machine.detail
    assert rig.machine.status().state is FAILED


def test_a_bad_plan_and_a_climb_at_the_wrong_time_are_refused():
    rig = ClimbRig(step_length=0.6)
    out = rig.call(rig.machine.step, +1)
    assert out.reply == (False, 'refused: no pose or grippers/state received yet') and out.status is None
    rig.tick()
    out = rig.call(rig.machine.step, +1)
    assert not out.reply[0] and 'stroke' in out.reply[1] and 'leg_' in out.reply[1]
    assert out.status.state is IDLE and out.status.detail.startswith('plan refused')
    assert rig.machine.plan_refused
    assert out.log == [(logging.WARNING, out.status.detail)]
    assert all(o.target is None for o in [rig.tick() for _ in range(5)])

    rig = ClimbRig()
    rig.engaged = True
    rig.tick()
    assert rig.call(rig.machine.step, +1).reply == (False, 'refused: teleoperation is engaged')
    rig.engaged = False
    rig.tick()
    assert rig.call(rig.machine.step, +1).reply[0]
    assert rig.call(rig.machine.step, -1).reply == (False, 'refused: a climb is executing')
    rig.driver_active = False
    rig.run_until(lambda s: s.state is PAUSED)
    busy = rig.call(rig.machine.step, -1)
    assert not busy.reply[0] and 'paused (driver inactive)' in busy.reply[1]


def test_a_scripted_climb_starts_once_the_state_is_known():
    rig = ClimbRig(auto_steps=1)
    out = rig.tick()
    assert out.status.state is EXECUTING
    assert out.log[-1][0] == logging.INFO and out.log[-1][1].startswith('scripted climb of 1 steps: started')
    rig.run_until(lambda s: s.state is IDLE)
    assert rig.machine.steps_done == 1
    assert all(o.status is None or o.status.state is not EXECUTING for o in [rig.tick() for _ in range(5)])


def test_a_robot_off_the_gait_is_brought_back_first():
    off = Pose(HOME.position + [0.015, 0.0, 0.0], HOME.quaternion_xyzw)
    rig = ClimbRig(pose=off, step_length=0.04)
    started(rig)
    rig.run_until(lambda s: s.state is IDLE)
    seen = [(s.step, s.phase) for _, s in rig.statuses() if s.state is EXECUTING]
    assert seen[:3] == [(0, 'release_b'), (0, 'move_b'), (0, 'grip_b')]
    plan = PLANNER.plan(0.04, 1, start=START)
    assert pose_error(rig.pose, plan.phases[-1].a_T_b)[0] < 1e-9
    assert rig.machine.s_a == pytest.approx(START + 0.04)


def test_an_answer_to_another_request_is_ignored():
    rig = ClimbRig()
    started(rig)
    rig.run_until(lambda s: rig.pending != [])
    [request], rig.pending = rig.pending, []             # the driver has not answered yet
    rig.machine.on_gripper_answer(GripperRequest('ring_b', False), False, 'not ours')
    assert all(out.gripper is None for out in [rig.tick() for _ in range(5)])
    assert rig.machine.status().state is EXECUTING and rig.machine.status().phase == 'release_b'
    rig.machine.on_gripper_answer(request, True)
    rig.grippers['ring_b'] = False
    rig.run_until(in_phase('move_b'))


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match='period'):
        StepConfig(period=0.0)
    with pytest.raises(ValueError, match='settle_time'):
        StepConfig(settle_time=-1.0)
    with pytest.raises(ValueError, match='does not fit'):
        ClimbStepMachine(PLANNER, start=2.99)
    with pytest.raises(ValueError, match='auto_steps'):
        ClimbStepMachine(PLANNER, auto_steps=-1)


ACCEPTED = ClimbPreview(accepted=True, peak_force=50.0, peak_leg=2, max_force=2000.0,
                        detail='peak force 50.0 N (leg_2)')


def _previewing() -> tuple[ClimbRig, object]:
    rig = ClimbRig(preview=True)
    rig.tick()
    return rig, rig.call(rig.machine.step, +1)


def test_a_previewed_step_stays_idle_until_its_preview_accepts_it():
    rig, out = _previewing()
    assert out.reply[0] and out.reply[1].startswith('previewing 1 step(s) of 0.060 m')
    assert [p.phase for p in out.preview][-6:] == ['release_b', 'move_b', 'grip_b', 'release_a', 'move_a', 'grip_a']
    assert out.status.state is IDLE and out.status.previewing and out.status.refusal is None
    assert all(o.target is None and o.gripper is None for o in [rig.tick() for _ in range(5)])
    assert rig.call(rig.machine.step, +1).reply == (False, 'refused: a step is being previewed')
    started = rig.call(rig.machine.on_preview, ACCEPTED)
    assert started.status.state is EXECUTING and not started.status.previewing
    # the step's planned duration: both grippers' open and close times and the two timed motions
    duration = started.status.step_duration
    assert duration > 2 * (0.5 + 0.8) and started.status.climbing_speed == pytest.approx(60.0 * STEP / duration)
    assert started.log == [(logging.INFO, f'started: 1 step(s) of 0.060 m, 10 phases, {duration:.1f} s per step, '
                                          f'{60.0 * STEP / duration:.2f} m/min (preview: peak force 50.0 N (leg_2))')]
    rig.run_until(lambda s: s.state is IDLE)
    assert rig.machine.steps_done == 1
    assert rig.call(rig.machine.on_preview, ACCEPTED).status is None     # nothing previewed: ignored


def test_a_step_whose_preview_breaks_a_limit_or_fails_is_refused():
    rig, _ = _previewing()
    broken = ClimbPreview(accepted=False, peak_force=2500.0, peak_leg=4, max_force=2000.0,
                          limit=PreviewLimit.ACTUATOR_FORCE,
                          detail='actuator force: leg_4 needs 2500.0 N > 2000 N at step 1 move_b, t=1.00 s')
    out = rig.call(rig.machine.on_preview, broken)
    assert out.status.state is IDLE and not out.status.previewing
    assert out.status.refusal is StepRefusal.PREVIEW_LIMIT and 'leg_4 needs 2500.0 N' in out.status.detail
    assert out.log == [(logging.WARNING, out.status.detail)] and rig.machine.plan_refused
    assert all(o.target is None and o.gripper is None for o in [rig.tick() for _ in range(5)])
    again = rig.call(rig.machine.step, +1)                                # a new request is previewed
    assert again.reply[0] and again.status.previewing and again.status.refusal is None
    failed = rig.call(rig.machine.on_preview, ClimbPreview(accepted=False, detail='preview failed: singular'))
    assert failed.status.refusal is StepRefusal.PREVIEW_FAILED and failed.status.state is IDLE


def _engage(rig):
    rig.engaged = True


def _deactivate(rig):
    rig.driver_active = False


def _engage_for_a_moment(rig):
    rig.engaged = True
    rig.tick()
    rig.engaged = False


def _deactivate_for_a_moment(rig):
    rig.driver_active = False
    rig.tick()
    rig.driver_active = True


def _move(rig):
    rig.pose = Pose(HOME.position + [0.004, 0.0, 0.0], HOME.quaternion_xyzw)


def _open(rig):
    rig.grippers['ring_b'] = False


@pytest.mark.parametrize('change, refusal', [(_engage, StepRefusal.TELEOP_ENGAGED),
                                             (_engage_for_a_moment, StepRefusal.TELEOP_ENGAGED),
                                             (_deactivate, StepRefusal.DRIVER_CHANGED),
                                             (_deactivate_for_a_moment, StepRefusal.DRIVER_CHANGED),
                                             (_move, StepRefusal.ROBOT_MOVED),
                                             (_open, StepRefusal.ROBOT_MOVED)])
def test_a_step_accepted_by_its_preview_starts_only_if_nothing_changed(change, refusal):
    rig, _ = _previewing()
    rig.tick()
    change(rig)
    rig.tick()
    out = rig.call(rig.machine.on_preview, ACCEPTED)
    assert out.status.state is IDLE and out.status.refusal is refusal
    assert out.status.detail.startswith('step refused: ') and 'while the step was previewed' in out.status.detail
    assert out.log == [(logging.WARNING, out.status.detail)]
    assert all(o.target is None and o.gripper is None for o in [rig.tick() for _ in range(5)])


def test_a_cancel_holds_the_step_as_a_pause_and_a_previewed_step_never_starts():
    """cancel (the climb/step action's): the motion brakes along its path, then no target and no
    gripper request, the grippers as they are; climb/resume goes on from there to the end of the step."""
    rig = ClimbRig()
    started(rig)
    rig.run_until(in_phase('move_b'))
    streamed = [rig.tick().target for _ in range(10)]
    index = rig.machine.status().phase_index
    assert 0 < index < rig.machine.status().phases
    out = rig.machine.cancel()
    assert out.reply[0] and rig.machine.status().pause_reason is PauseReason.CANCELLED
    held = [rig.tick() for _ in range(50)]
    assert all(o.gripper is None for o in held)
    assert_brakes(streamed, held)
    assert rig.machine.status().state is PAUSED and rig.grippers == {'ring_a': True, 'ring_b': False}
    assert rig.call(rig.machine.resume).reply[0]
    rig.run_until(lambda s: s.state is IDLE)
    assert rig.machine.steps_done == 1 and not rig.both_open
    previewed = ClimbRig(preview=True)
    started(previewed)
    assert previewed.machine.status().previewing
    previewed.machine.cancel()
    assert not previewed.machine.status().previewing
    accepted = ClimbPreview(accepted=True, peak_force=1.0, max_force=2.0)
    assert previewed.call(previewed.machine.on_preview, accepted).target is None
    assert previewed.machine.status().state is IDLE
