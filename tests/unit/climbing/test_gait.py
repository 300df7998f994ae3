"""Inchworm gait: every limit along every motion, the interlock, odometry, the frame junction."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_climbing.gait import GaitPlanner, plan_climb
from rrps_climbing.plan import PlanError, check_interlock
from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.rotations import matrix_to_quat_xyzw, rotation_vector_to_quat_xyzw
from rrps_description.structures import facade, palm_trunk, pole, structural_frame
from rrps_kinematics import inverse_kinematics, margins
from rrps_kinematics.odometry import InterlockError, RingOdometry, invert

CASES = {
    'pole': ('pole_climber', lambda: pole(3.0), 0.8, 11),
    'palm_trunk': ('pole_climber', lambda: palm_trunk(3.0), 2.4, None),
    'frame': ('frame_climber', lambda: structural_frame(), 2.5, None),
    'frame_bent': ('frame_climber', lambda: structural_frame(bend_deg=10.0), 2.5, 12),
    'facade': ('facade_climber', lambda: facade(4.0), 3.0, None),
}


@pytest.fixture(scope='module')
def plans():
    out = {}
    for key, (robot, make, distance, steps) in CASES.items():
        planner = GaitPlanner(load_robot(robot), make())
        out[key] = (planner, planner.plan(distance, steps))
    return out


@pytest.mark.parametrize('key', list(CASES))
def test_every_sampled_pose_keeps_every_limit(plans, key):
    planner, plan = plans[key]
    g = planner.geometry
    path = np.concatenate([ph.path for ph in plan.phases])
    m = margins(g, inverse_kinematics(g, path[:, :3, 3], matrix_to_quat_xyzw(path[:, :3, :3])))
    assert np.all(m.ok), m.violations()[:3]
    for ph in plan.phases:
        assert all(v >= 0.0 for v in ph.min_margins.values() if not np.isnan(v)), (ph.step, ph.phase)
    # Motions are sampled finely: no jump between consecutive checked poses > spacing (+ rotation).
    for ph in plan.phases:
        if ph.phase.startswith('move'):
            assert np.max(np.linalg.norm(np.diff(ph.path[:, :3, 3], axis=0), axis=1)) < 2 * planner.spacing


@pytest.mark.parametrize('key', list(CASES))
def test_interlock_on_every_phase(plans, key):
    _, plan = plans[key]
    grips = np.array([(ph.gripper_a, ph.gripper_b) for ph in plan.phases])
    assert np.all(grips.any(axis=1))                                 # never both open
    assert np.all(np.abs(np.diff(grips.astype(int), axis=0)).sum(axis=1) <= 1)  # one switch at a time
    for prev, ph in zip(plan.phases[:-1], plan.phases[1:]):
        moved = not np.allclose(ph.a_T_b.matrix, prev.a_T_b.matrix, atol=1e-9)
        if moved:
            assert ph.phase.startswith('move') and grips[plan.phases.index(ph)].sum() == 1
        if ph.s_a != prev.s_a:
            assert not ph.gripper_a and ph.gripper_b
        if ph.s_b != prev.s_b:
            assert not ph.gripper_b and ph.gripper_a
    check_interlock(plan.phases)


@pytest.mark.parametrize('key', list(CASES))
def test_odometry_matches_the_structure(plans, key):
    """The chained odometry (a_T_b + grippers only) lands every ring on its grip frame."""
    planner, plan = plans[key]
    for ph in plan.phases:
        wa, wb = planner.world_rings(ph.s_a, ph.s_b, ph.theta_a, ph.theta_b)
        assert np.allclose(ph.world_T_a.matrix, wa.matrix, atol=1e-7), (ph.step, ph.phase)
        assert np.allclose(ph.world_T_b.matrix, wb.matrix, atol=1e-7), (ph.step, ph.phase)
        assert np.allclose(invert(ph.world_T_a.matrix) @ ph.world_T_b.matrix, ph.a_T_b.matrix,
                           atol=1e-9)


def test_pole_climber_800_mm_in_11_steps(plans):
    planner, plan = plans['pole']
    assert plan.steps == 11 and plan.step_length == pytest.approx(0.8 / 11)
    assert plan.climbed == pytest.approx(0.8)
    ends = [ph for ph in plan.phases if ph.phase == 'grip_a']
    assert len(ends) == 11
    assert np.allclose([ph.world_T_a.position[2] for ph in ends], 0.8 / 11 * np.arange(1, 12))
    assert np.allclose(plan.phases[-1].world_T_a.position, [0.0, 0.0, 0.8])


def test_palm_trunk_is_followed_with_tilted_rings(plans):
    planner, plan = plans['palm_trunk']
    assert plan.climbed == pytest.approx(2.4)
    tilt = max(np.arccos(np.clip(ph.a_T_b.rotation[2, 2], -1, 1)) for ph in plan.phases)
    assert tilt > 0.03  # the rings' relative pose tilts to follow the curvature
    assert plan.phases[-1].s_b <= planner.structure.length  # stayed on the 3 m trunk
    assert plan.min_margins['clearance'] > 0.0              # legs clear of the swollen trunk


def test_frame_junction_needs_the_extra_dof(plans):
    """The Figure 8c problem: without the extra ring DOF the junction's 90 deg section turn twists
    ring_b against ring_a and the intermediate actuators of a pair touch; that, and nothing
    else, is the first limit the motion breaks. With the DOF the same climb passes."""
    planner, plan = plans['frame']
    junction = planner.structure.junctions[0]
    assert plan.phases[-1].s_a > junction and plan.phases[-1].s_b > junction
    assert abs(plan.phases[-1].theta_b) == pytest.approx(np.pi / 2, abs=1e-6)
    with pytest.raises(PlanError) as info:
        plan_climb(planner.geometry, planner.structure, 2.5, use_extra_dof=False)
    err = info.value
    assert err.limit == 'interference' and err.legs == ('leg_1', 'leg_2')
    assert err.phase == 'move_b' and str(err).startswith(f'step {err.step}, phase move_b')
    assert '): interference: leg_1 and leg_2 are ' in str(err)  # the first violation named
    # Only interference is broken at the first pose that breaks a limit: stroke, joint cones and
    # conditioning still have room there (the planner stops at the first such pose).
    assert err.margins['interference'] < 0.0
    assert all(err.margins[k] > 0.0 for k in ('stroke', 'universal', 'spherical', 'conditioning'))
    # It breaks while ring_b crosses the junction (the move that turns its gripper).
    crossing = next(ph for ph in plan.phases if ph.phase == 'move_b' and ph.s_b > junction)
    assert err.step == crossing.step


def test_frame_plan_with_the_extra_dof_keeps_the_legs_apart(plans):
    """Every sampled pose of the frame climb (with the DOF) is within every limit, the rings never
    twist against each other, and the interference margin stays positive all along."""
    planner, plan = plans['frame']
    g = planner.geometry
    path = np.concatenate([ph.path for ph in plan.phases])
    m = margins(g, inverse_kinematics(g, path[:, :3, 3], matrix_to_quat_xyzw(path[:, :3, :3])))
    assert np.all(m.ok)
    assert np.min(m.interference) > 0.05          # > 50 mm between the 100 mm thick actuators
    assert np.min(m.interference) == pytest.approx(plan.min_margins['interference'])
    twist = np.arctan2(path[:, 1, 0], path[:, 0, 0])
    assert np.max(np.abs(twist)) < 1e-9


def test_frame_climber_legs_touch_when_the_rings_twist():
    """The interference margin of the frame climber along a relative twist of the rings about
    the member axis (at the home height): it falls steadily, and interference is the first limit
    broken, well before the junction's 90 deg."""
    g = load_robot('frame_climber')
    deg = np.arange(0.0, 90.5, 0.5)
    q = np.array([rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, np.radians(d)])) for d in deg])
    m = margins(g, inverse_kinematics(g, np.tile(g.home_position, (len(deg), 1)), q))
    inter = m.minimum['interference']
    assert inter[0] > 0.05 and inter[-1] < -0.05
    assert np.all(np.diff(inter) < 0.0)
    first = int(np.flatnonzero(~np.asarray(m.ok))[0])
    assert 30.0 <= deg[first] <= 60.0
    assert m.violations()[0].startswith(f'pose {first}: interference: leg_1 and leg_2')
    for kind in ('stroke', 'universal', 'spherical', 'conditioning'):
        assert np.all(m.minimum[kind][:first + 20] > 0.0), kind  # 10 deg further still inside


def test_refusal_names_limit_legs_step_and_phase():
    g = load_robot('pole_climber')
    with pytest.raises(PlanError) as info:
        plan_climb(g, pole(3.0), 0.8, 1)  # one 800 mm step: beyond the stroke
    err = info.value
    assert err.limit == 'stroke'
    assert err.legs and all(leg.startswith('leg_') for leg in err.legs)
    assert str(err).startswith(f'step {err.step}, phase {err.phase}')
    assert 'min_length' in str(err) or 'max_length' in str(err)


def test_climb_down_returns_to_the_start():
    g = load_robot('pole_climber')
    planner = GaitPlanner(g, pole(3.0))
    up = planner.plan(0.5, 4, start=0.2)
    last = up.phases[-1]
    down = planner.plan(-0.5, 4, start=last.s_a, initial_separation=last.s_b - last.s_a)
    assert [ph.phase for ph in down.phases[:3]] == ['start', 'release_a', 'move_a']  # ring_a leads
    assert down.phases[-1].s_a == pytest.approx(0.2)
    assert np.allclose(down.phases[-1].world_T_a.position, [0.0, 0.0, 0.2])


def test_facade_rings_stay_on_the_plane(plans):
    planner, plan = plans['facade']
    for ph in plan.phases:
        if ph.gripper_a:
            assert ph.world_T_a.position[1] == pytest.approx(0.0, abs=1e-9)
    # a traverse: the rings move along x, their axes stay the wall normal
    assert plan.phases[-1].world_T_a.position[0] - plan.phases[0].world_T_a.position[0] == pytest.approx(3.0)
    assert np.allclose(plan.phases[-1].world_T_a.rotation[:, 2], [0.0, -1.0, 0.0])


def test_check_interlock_catches_bad_sequences(plans):
    _, plan = plans['pole']
    phases = copy.deepcopy(plan.phases[:4])
    phases[2].gripper_a = False  # move_b with ring_a open too
    with pytest.raises(PlanError, match='both grippers open') as info:
        check_interlock(phases)
    assert info.value.limit == 'interlock'
    phases = copy.deepcopy(plan.phases[:4])
    phases[2].gripper_b = True   # ring_b moves while gripping
    with pytest.raises(PlanError, match='interlock'):
        check_interlock(phases)


def test_bad_requests_raise_value_error():
    g = load_robot('pole_climber')
    with pytest.raises(ValueError, match='distance'):
        plan_climb(g, pole(3.0), 0.0)
    with pytest.raises(ValueError, match='steps'):
        plan_climb(g, pole(3.0), 0.5, 0)
    with pytest.raises(ValueError, match='leaves the pole'):
        plan_climb(g, pole(3.0), 5.0)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2), st.floats(0.3, 0.5),
                          st.floats(-0.3, 0.3), st.booleans()), min_size=1, max_size=8))
def test_odometry_keeps_the_gripping_ring_fixed(moves):
    """Whatever a_T_b does, the ring that grips stays put; with both closed ring_a is the reference."""
    odo = RingOdometry(Pose([1.0, 2.0, 3.0], [0, 0, 0, 1]), Pose([0, 0, 0.4], [0, 0, 0, 1]))
    for x, y, z, angle, a_grips in moves:
        a_T_b = Pose([x, y, z], rotation_vector_to_quat_xyzw(np.array([angle, 0.0, 0.0])))
        before_a, before_b = odo.world_T_a, odo.world_T_b
        odo.update(a_T_b, a_grips, not a_grips)
        fixed, moved = (odo.world_T_a, before_a) if a_grips else (odo.world_T_b, before_b)
        assert np.allclose(fixed.matrix, moved.matrix, atol=1e-9)
        assert np.allclose(invert(odo.world_T_a.matrix) @ odo.world_T_b.matrix, a_T_b.matrix,
                           atol=1e-9)
    with pytest.raises(InterlockError):
        odo.update(Pose(), False, False)


def test_approach_brings_ring_b_back_to_the_gait():
    g = load_robot('pole_climber')
    planner = GaitPlanner(g, pole(3.0))
    off = Pose(g.home_position + [0.02, -0.01, 0.0], rotation_vector_to_quat_xyzw(np.array([0.05, 0, 0])))
    phases = planner.approach(off, 0.2, 0.2 + planner.sep_home)
    assert [ph.phase for ph in phases] == ['release_b', 'move_b', 'grip_b']
    assert np.allclose(phases[0].a_T_b.matrix, off.matrix) and np.allclose(phases[1].path[0], off.matrix)
    assert np.allclose(phases[-1].a_T_b.matrix, Pose(g.home_position, [0, 0, 0, 1]).matrix)
    check_interlock(phases + planner.plan(0.1, 1, start=0.2).phases)
    beyond = Pose(g.home_position + [0.0, 0.0, 0.2], [0, 0, 0, 1])  # legs past max_length
    with pytest.raises(PlanError, match='stroke') as info:
        planner.approach(beyond, 0.2, 0.2 + planner.sep_home)
    assert info.value.step == 0 and info.value.phase == 'release_b'
