"""Loads along a climbing plan (rrps_loads.path_loads through the planner's load check), checked at
points of real plans against computations written here from the robot description alone:
virtual work with a finite-difference Jacobian of the leg lengths with respect to the moving
ring's pose (from the anchors), the moving ring's accelerations differentiated here from the
plan's samples, and the whole robot's momentum balance for the holding ring's reaction. Then
the planner's refusals (holding, actuator force: the limit, the ring or leg, where) and the
figures of plans that pass."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.load_check import LoadCheck
from rrps_climbing.plan import PlanError, PlanLimit
from rrps_description.geometry import load_robot
from rrps_description.loads import Payload, ToolWrench
from rrps_description.pose import Pose
from rrps_description.robot_parts import LinkInertia
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_description.structures import make_structure
from rrps_loads.loads import holding_margin
from rrps_testing.virtual_work import moving_ring_dynamics

G_WORLD = np.array([0.0, 0.0, -9.81])
LIGHT = LinkInertia(mass=1e-9, com_from_joint=0.1, inertia_transverse=1e-12, inertia_axial=1e-12)
LEAN_30 = tuple(rotation_vector_to_quat_xyzw(np.array([np.radians(30.0), 0.0, 0.0])))
#: (robot, structure, distance, structure attitude in the world, speed [m/s], tool wrench,
#: whether its motions accelerate): a wall (gravity in the rings' plane; the gripper lifts off,
#: moves and sets down), a curved palm trunk leaning 30° with a drilling thrust, and a frame
#: leaning 30° (straight moves at constant speed: quasi-static).
PLANS = [
    ('facade_climber', 'facade', 0.6, (0.0, 0.0, 0.0, 1.0), 0.1, None, True),
    ('pole_climber', 'palm_trunk', 0.6, LEAN_30, 1.0, ToolWrench(force=np.array([0.0, 0.0, 40.0])), True),
    ('frame_climber', 'frame', 1.0, LEAN_30, 0.5, None, False),
]


def _plan(robot, structure, distance, world_q, speed, tool_wrench, legs=LIGHT):
    geom = load_robot(robot)
    geom = geom.with_(lower_link=legs, upper_link=legs, tool_wrench=tool_wrench or geom.tool_wrench)
    check = LoadCheck(speed=speed, world_q_structure=world_q)
    planner = GaitPlanner(geom, make_structure(structure, distance + 2.0), loads=check)
    return geom, check, planner.plan(distance)


def _times(path, speed, c):
    """The plan's timing law, written here: arc length of positions plus c times the angle."""
    R = path[:, :3, :3]
    cosine = (np.einsum('kij,kij->k', R[:-1], R[1:]) - 1.0) / 2.0
    seg = np.linalg.norm(np.diff(path[:, :3, 3], axis=0), axis=1) + c * np.arccos(np.clip(cosine, -1, 1))
    return np.concatenate([[0.0], np.cumsum(seg)]) / speed


def _derivatives(t, y, k):
    """First and second derivatives at t[k] of the degree-6 polynomial through 7 samples."""
    window = slice(k - 3, k + 4)
    coef = np.polyfit(t[window] - t[k], y[window].reshape(7, -1), 6)
    return coef[-2].reshape(y.shape[1:]), 2.0 * coef[-3].reshape(y.shape[1:])


def _moving(geom, ph):
    """(support ring, moving ring's poses (K, 4, 4) in the support's frame)."""
    if ph.gripper_a:
        return 'ring_a', ph.path
    return 'ring_b', np.linalg.inv(ph.path)


def _expected(geom, ph, check, k, moves=True):
    """Actuator forces (6,) and the structure's wrench on the holding ring (6,) at sample k of a
    move phase with massless legs: virtual work on the moving ring, in the holding ring's frame
    (``moves=False``: the same pose at rest)."""
    support, T = _moving(geom, ph)
    world_T_s = ph.world_T_a if support == 'ring_a' else ph.world_T_b
    g = (quat_xyzw_to_matrix(np.asarray(check.world_q_structure)) @ world_T_s.rotation).T @ G_WORLD
    moving = geom.ring_b_body if support == 'ring_a' else geom.ring_a_body
    t = _times(ph.path, check.speed, geom.characteristic_length)
    R, p = T[k, :3, :3], T[k, :3, 3]
    dR, ddR = _derivatives(t, T[:, :3, :3], k)
    dp, ddp = _derivatives(t, T[:, :3, 3], k)
    if not moves:
        dR, ddR, ddp = 0.0 * dR, 0.0 * ddR, 0.0 * ddp
    W = dR @ R.T
    A = ddR @ R.T - W @ W
    return moving_ring_dynamics(geom, support, g, R, p, np.array([W[2, 1], W[0, 2], W[1, 0]]),
                                np.array([A[2, 1], A[0, 2], A[1, 0]]), ddp + ddR @ moving.com)


@pytest.mark.parametrize('robot,structure,distance,world_q,speed,tool,accelerates', PLANS)
def test_forces_and_reaction_match_virtual_work_along_a_real_plan(robot, structure, distance, world_q,
                                                                 speed, tool, accelerates):
    geom, check, plan = _plan(robot, structure, distance, world_q, speed, tool)
    moves = [ph for ph in plan.phases if ph.action.value == 'move' and len(ph.path) >= 9]
    assert {_moving(geom, ph)[0] for ph in moves} == {'ring_a', 'ring_b'}
    dynamic = 0.0
    for ph in moves[:4]:
        loads, kept, _ = check.phase_loads(geom, ph)
        assert len(kept) == len(ph.path)
        for k in (3, len(ph.path) // 2, len(ph.path) - 4):
            f, wrench = _expected(geom, ph, check, k)
            scale = max(1.0, np.abs(f).max())
            np.testing.assert_allclose(loads.actuator_forces[k], f, atol=2e-4 * scale)
            np.testing.assert_allclose(loads.support_wrench[k], wrench, atol=2e-4 * np.abs(wrench).max())
            capacity = geom.holding[loads.support.ring]
            assert loads.holding_margin[k] == pytest.approx(holding_margin(capacity, wrench), abs=1e-4)
            dynamic = max(dynamic, np.abs(f - _expected(geom, ph, check, k, moves=False)[0]).max() / scale)
    assert (dynamic > 0.01) == accelerates   # where the plan accelerates, its inertia counts


def test_a_heavy_payload_is_refused_for_holding_at_the_first_release():
    geom = load_robot('pole_climber').with_(payload=Payload(ring='ring_b', mass=200.0))
    with pytest.raises(PlanError) as err:
        GaitPlanner(geom, make_structure('pole', 3.0)).plan(0.5)
    e = err.value
    assert (e.limit, e.ring, e.legs, e.step, e.phase, e.pose, e.fraction) == (
        PlanLimit.HOLDING, 'ring_a', (), 0, 'release_b', 0, 0.0)
    assert str(e).startswith('holding, ring_a, step 0 release_b, pose 1/1')
    # Here the whole robot and its payload hang on ring_a's friction clamp, at rest.
    weight = 9.81 * geom.total_mass
    capacity = geom.holding['ring_a']
    assert e.margins['holding'] == pytest.approx(1.0 - weight / (capacity.friction * capacity.clamp_force), abs=0.01)
    assert e.margins['holding'] < 0.0


def test_a_weak_actuator_is_refused_where_its_force_first_exceeds_the_limit():
    geom = load_robot('facade_climber')
    plan = GaitPlanner(geom, make_structure('facade', 3.0)).plan(1.0)
    peak = plan.peak_load.peak_force
    weak = geom.with_(max_force=0.8 * peak)
    with pytest.raises(PlanError) as err:
        GaitPlanner(weak, make_structure('facade', 3.0)).plan(1.0)
    e = err.value
    assert e.limit is PlanLimit.ACTUATOR_FORCE and e.ring is None and len(e.legs) == 1
    # The same phase of the passing plan: every phase before it stays within the weak limit,
    # and at the reported pose the reported leg carries the largest force, above the limit.
    check = LoadCheck()
    index = next(i for i, ph in enumerate(plan.phases) if (ph.step, ph.phase) == (e.step, e.phase))
    for ph in plan.phases[:index]:
        if ph.loads is not None:
            assert ph.loads.peak_force <= weak.max_force
    ph = plan.phases[index]
    loads, kept, fractions = check.phase_loads(geom, ph)
    f = loads.actuator_forces[list(kept).index(e.pose)]
    assert e.legs == (f'leg_{np.argmax(np.abs(f)) + 1}',) and np.abs(f).max() > weak.max_force
    assert np.all(np.abs(loads.actuator_forces[:list(kept).index(e.pose)]) <= weak.max_force)
    assert e.fraction == pytest.approx(fractions[list(kept).index(e.pose)])
    assert str(e).startswith(f'actuator_force, {e.legs[0]}, step {e.step} {e.phase}, pose {e.pose + 1}/')


def test_ordinary_climbs_of_the_shipped_robots_plan_with_their_load_figures():
    for robot, structure, distance in (('pole_climber', 'pole', 0.5), ('facade_climber', 'facade', 1.0),
                                       ('frame_climber', 'frame', 1.0)):
        geom = load_robot(robot)
        plan = GaitPlanner(geom, make_structure(structure, 3.0)).plan(distance)
        held = [ph for ph in plan.phases if ph.gripper_a != ph.gripper_b]
        assert held and all(ph.loads is not None for ph in held)
        assert all(ph.loads is None for ph in plan.phases if ph.gripper_a == ph.gripper_b)
        peak = plan.peak_load
        assert 0.0 < peak.peak_force < geom.max_force and 0.0 < peak.holding_margin < 1.0
        assert peak.peak_force == max(ph.loads.peak_force for ph in held)
        # The plan's phases are computed in batches (one per holding ring and attitude): each
        # phase alone gives the same figures.
        for ph in held[:6]:
            alone = LoadCheck().phase_loads(geom, ph)[0]
            assert ph.loads.peak_force == pytest.approx(alone.peak_force, rel=1e-9, abs=1e-9)
            assert ph.loads.holding_margin == pytest.approx(alone.min_holding_margin, rel=1e-9, abs=1e-9)
        rows = plan.rows()
        assert max(r['peak_force'] for r in rows if not np.isnan(r['peak_force'])) == peak.peak_force
    # Without the check the same plan comes out, without figures.
    bare = GaitPlanner(geom, make_structure(structure, 3.0), loads=None).plan(distance)
    assert bare.peak_load is None and len(bare.phases) == len(plan.phases)


@pytest.mark.parametrize('kwargs', [{'speed': 0.0}, {'speed': float('nan')}, {'world_q_structure': (0, 0, 0, 2)},
                                    {'gravity': (0.0, 9.81)}])
def test_bad_load_check_settings_are_a_value_error(kwargs):
    with pytest.raises(ValueError):
        LoadCheck(**kwargs)


def test_bringing_ring_b_back_to_the_gait_is_load_checked_too():
    geom = load_robot('pole_climber')
    planner = GaitPlanner(geom, make_structure('pole', 3.0))
    off = Pose(geom.home_position + [0.015, 0.0, 0.0], geom.home_quaternion_xyzw)
    phases = planner.approach(off, 0.2, 0.2 + geom.home_position[2])
    assert [ph.loads is not None for ph in phases] == [True, True, False]
    heavy = GaitPlanner(geom.with_(payload=Payload(ring='ring_b', mass=200.0)), make_structure('pole', 3.0))
    with pytest.raises(PlanError) as err:
        heavy.approach(off, 0.2, 0.2 + geom.home_position[2])
    assert (err.value.limit, err.value.ring, err.value.phase) == (PlanLimit.HOLDING, 'ring_a', 'release_b')
