"""A plan's preview (climbing.step_preview): its motions as the step machine streams them, each on
the ring whose gripper holds with that ring's world attitude; the typed preview of a step that
keeps its limits and of one that breaks them."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.step_preview import PreviewConfig, preview_motions, run_preview
from rrps_description.geometry import load_robot
from rrps_description.pose import Pose, pose_error
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_description.structures import facade, pole
from rrps_interfaces.climb import ClimbPreview, PhaseAction, PreviewLimit

POLE = load_robot('pole_climber')
PLAN = GaitPlanner(POLE, pole(3.0)).plan(0.06, 1, start=0.2)
PERIOD = 0.02


def test_each_motion_is_streamed_on_the_ring_that_holds_with_its_world_attitude():
    g = load_robot('facade_climber')
    plan = GaitPlanner(g, facade(4.0)).plan(0.1, 1, start=0.2)
    motions = preview_motions(plan.phases, period=PERIOD)
    moves = [ph for ph in plan.phases if ph.action is PhaseAction.MOVE]
    assert [m.name for m in motions] == [f'step {ph.step} {ph.phase}' for ph in moves]
    for m, ph in zip(motions, moves):
        holding = 'ring_a' if ph.phase == 'move_b' else 'ring_b'
        world_T = ph.world_T_a if holding == 'ring_a' else ph.world_T_b
        assert m.support == holding and np.allclose(m.world_q_support, world_T.quaternion_xyzw)
        # exactly the timed motion the climb node streams: its sample every period
        assert m.period == PERIOD and m.duration == pytest.approx(ph.timing.duration, abs=PERIOD)
        for k in (0, len(m.positions) // 2, len(m.positions) - 1):
            assert pose_error(ph.timing.at(min(k * PERIOD, ph.timing.duration))[0], _pose(m, k))[0] < 1e-12
        first, last = Pose.from_matrix(ph.path[0]), ph.a_T_b
        assert pose_error(first, _pose(m, 0))[0] < 1e-9 and pose_error(last, _pose(m, -1))[0] < 1e-9
    # on the wall the rings' axes are horizontal: gravity lies in their plane
    R = quat_xyzw_to_matrix(np.asarray(motions[0].world_q_support))
    assert abs((R.T @ [0.0, 0.0, -9.81])[2]) < 1e-9


def _pose(motion, i):
    return Pose(motion.positions[i], motion.quaternions[i])


def test_the_preview_of_a_step_is_typed_and_refuses_a_broken_limit():
    ok = run_preview(POLE, PLAN.phases, period=PERIOD)
    assert isinstance(ok, ClimbPreview) and ok.accepted and ok.limit is None
    assert 0.0 < ok.peak_force < POLE.max_force and 1 <= ok.peak_leg <= 6
    assert ok.peak_reaction_force > 9.81 * POLE.total_mass * 0.99
    assert 0.0 < ok.min_margin < 1.0 and ok.min_margin_ring in ('ring_a', 'ring_b')
    assert ok.simulated > sum(ph.duration for ph in PLAN.phases if ph.timing is not None) and ok.wall > 0.0
    assert ClimbPreview.from_values(ok.to_values()).to_values() == ok.to_values()
    strict = run_preview(POLE, PLAN.phases, period=PERIOD, config=PreviewConfig(min_margin=0.999))
    assert not strict.accepted and strict.limit is PreviewLimit.HOLDING
    assert strict.detail.startswith('holding: ') and 'move_' in strict.detail
    start_only = run_preview(POLE, PLAN.phases[:1], period=PERIOD)
    assert start_only.accepted and start_only.detail == 'no motion'
