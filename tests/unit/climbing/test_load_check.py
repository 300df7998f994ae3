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
from rrps_description.rotations import matrix_to_quat_xyzw, quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_description.structures import make_structure
from rrps_loads.loads import holding_margin, static_solution
from rrps_testing.virtual_work import moving_ring_dynamics

G_WORLD = np.array([0.0, 0.0, -9.81])
LIGHT = LinkInertia(mass=1e-9, com_from_joint=0.1, inertia_transverse=1e-12, inertia_axial=1e-12)
LEAN_30 = tuple(rotation_vector_to_quat_xyzw(np.array([np.radians(30.0), 0.0, 0.0])))
#: (robot, structure, distance, structure attitude in the world, tool wrench): a wall (gravity in
#: the rings' plane; the gripper lifts off, moves and sets down), a curved palm trunk leaning 30°
#: with a drilling thrust, and a frame leaning 30°.
PLANS = [
    ('facade_climber', 'facade', 0.6, (0.0, 0.0, 0.0, 1.0), None),
    ('pole_climber', 'palm_trunk', 0.6, LEAN_30, ToolWrench(force=np.array([0.0, 0.0, 40.0]))),
    ('frame_climber', 'frame', 1.0, LEAN_30, None),
]


def _plan(robot, structure, distance, world_q, tool_wrench, legs=LIGHT):
    geom = load_robot(robot)
    geom = geom.with_(lower_link=legs, upper_link=legs, tool_wrench=tool_wrench or geom.tool_wrench)
    check = LoadCheck(world_q_structure=world_q)
    planner = GaitPlanner(geom, make_structure(structure, distance + 2.0), loads=check)
    return geom, check, planner.plan(distance)


def _derivatives(timing, t, h=0.004):
    """Pose (R, p) of ring_b at time t of a timed motion and its first and second time
    derivatives, from the degree-4 polynomial through 5 samples h apart (written here)."""
    times = t + h * np.arange(-2, 3)
    p, q, _ = timing.poses(times)
    R = np.array([quat_xyzw_to_matrix(x) for x in q])
    coef_p = np.polyfit(times - t, p, 4)
    coef_R = np.polyfit(times - t, R.reshape(5, 9), 4)
    return (R[2], p[2], coef_R[-2].reshape(3, 3), 2.0 * coef_R[-3].reshape(3, 3), coef_p[-2], 2.0 * coef_p[-3])


def _moving(ph, T):
    """(support ring, the moving ring's pose matrix from a_T_b)."""
    return ('ring_a', T) if ph.gripper_a else ('ring_b', np.linalg.inv(T))


def _expected(geom, ph, check, t):
    """Actuator forces (6,) and the structure's wrench on the holding ring (6,) at time t of a move
    phase's timed motion, massless legs: virtual work on the moving ring, in the holding ring's
    frame, with its accelerations differentiated here from the timed poses."""
    R, p, dR, ddR, dp, ddp = _derivatives(ph.timing, t)
    support = 'ring_a' if ph.gripper_a else 'ring_b'
    if support == 'ring_b':   # the moving ring seen from ring_b: T^-1, differentiated the same way
        Ri, pi = R.T, -R.T @ p
        dRi = -R.T @ dR @ R.T
        ddRi = -(dRi @ dR @ R.T + R.T @ ddR @ R.T + R.T @ dR @ dRi)
        dpi = -(dRi @ p + R.T @ dp)
        ddpi = -(ddRi @ p + 2 * dRi @ dp + R.T @ ddp)
        R, p, dR, ddR, dp, ddp = Ri, pi, dRi, ddRi, dpi, ddpi
    world_T_s = ph.world_T_a if support == 'ring_a' else ph.world_T_b
    g = (quat_xyzw_to_matrix(np.asarray(check.world_q_structure)) @ world_T_s.rotation).T @ G_WORLD
    moving = geom.ring_b_body if support == 'ring_a' else geom.ring_a_body
    W = dR @ R.T
    A = ddR @ R.T - W @ W
    return moving_ring_dynamics(geom, support, g, R, p, np.array([W[2, 1], W[0, 2], W[1, 0]]),
                                np.array([A[2, 1], A[0, 2], A[1, 0]]), ddp + ddR @ moving.com)


@pytest.mark.parametrize('robot,structure,distance,world_q,tool', PLANS)
def test_loads_of_the_timed_motion_match_virtual_work_with_its_accelerations(robot, structure, distance, world_q,
                                                                              tool):
    geom, check, plan = _plan(robot, structure, distance, world_q, tool)
    moves = [ph for ph in plan.phases if ph.timing is not None and ph.timing.duration > 1.0]
    assert {'ring_a' if ph.gripper_a else 'ring_b' for ph in moves} == {'ring_a', 'ring_b'}
    dynamic = 0.0
    for ph in moves[:4]:
        timing = ph.timing
        loads, times = timing.loads, timing.load_times
        for k in (len(times) // 7, len(times) // 3, len(times) // 2, 4 * len(times) // 5):
            if not 0.01 < times[k] < timing.duration - 0.01:
                continue
            f, wrench = _expected(geom, ph, check, times[k])
            scale = max(1.0, np.abs(f).max())
            np.testing.assert_allclose(loads.actuator_forces[k], f, atol=2e-3 * scale)
            np.testing.assert_allclose(loads.support_wrench[k], wrench, atol=2e-3 * np.abs(wrench).max())
            capacity = geom.holding[loads.ring]
            assert loads.holding_margin[k] == pytest.approx(holding_margin(capacity, wrench), abs=1e-3)
        static = loads.support_wrench - loads.support_wrench.mean(axis=0)
        dynamic = max(dynamic, float(np.abs(static).max()))
    assert dynamic > 0.1   # the timed motion accelerates: its loads change along it


def test_a_heavy_payload_is_refused_for_holding_before_anything_moves():
    geom = load_robot('pole_climber').with_(payload=Payload(ring='ring_b', mass=200.0))
    with pytest.raises(PlanError) as err:
        GaitPlanner(geom, make_structure('pole', 3.0)).plan(0.5)
    e = err.value
    # even shared by both grippers (the start's hand-over) the robot and its payload slip
    assert (e.limit, e.ring, e.legs, e.step, e.phase) == (PlanLimit.HOLDING, 'ring_a', (), 0, 'start')
    assert str(e).startswith('holding, ring_a, step 0 start (hand-over')
    # Here the whole robot and its payload hang on the two friction clamps, at rest: the
    # minimum-norm split gives each about half of the weight (the rings are coaxial on the pole)
    weight = 9.81 * geom.total_mass
    capacity = geom.holding['ring_a']
    assert e.margins['holding'] == pytest.approx(1.0 - 0.5 * weight / (capacity.friction * capacity.clamp_force),
                                                 abs=0.05)
    assert e.margins['holding'] < 0.0


def test_a_weak_actuator_slows_the_motion_and_is_refused_only_past_its_limit_at_rest():
    geom = load_robot('facade_climber')
    plan = GaitPlanner(geom, make_structure('facade', 3.0)).plan(1.0)
    rest = 0.0   # the largest force holding a pose of the plan at rest (rrps_sim's statics)
    for ph in plan.phases:
        if ph.gripper_a != ph.gripper_b:
            ring = 'ring_a' if ph.gripper_a else 'ring_b'
            world_q = (ph.world_T_a if ring == 'ring_a' else ph.world_T_b).quaternion_xyzw
            still = static_solution(geom, (ph.path[:, :3, 3], matrix_to_quat_xyzw(ph.path[:, :3, :3])), support=ring,
                                    world_q_support=world_q)
            rest = max(rest, float(np.abs(still.actuator_forces).max()))
    peak = plan.peak_load.peak_force
    assert peak > rest
    # between the loads at rest and the plan's peak: timed slower, every force within the limit
    weak = geom.with_(max_force=0.5 * (peak + rest))
    slow = GaitPlanner(weak, make_structure('facade', 3.0)).plan(1.0)
    assert slow.peak_load.peak_force <= weak.max_force and slow.duration >= plan.duration
    # below the loads of a pose at rest: refused there, naming the leg
    weaker = geom.with_(max_force=0.5 * rest)
    with pytest.raises(PlanError) as err:
        GaitPlanner(weaker, make_structure('facade', 3.0)).plan(1.0)
    e = err.value
    assert e.limit is PlanLimit.ACTUATOR_FORCE and e.ring is None and len(e.legs) == 1
    assert str(e).startswith(f'actuator_force, {e.legs[0]}, step {e.step} {e.phase}')


def test_ordinary_climbs_of_the_shipped_robots_plan_with_their_load_figures():
    for robot, structure, distance in (('pole_climber', 'pole', 0.5), ('facade_climber', 'facade', 1.0),
                                       ('frame_climber', 'frame', 1.0)):
        geom = load_robot(robot)
        plan = GaitPlanner(geom, make_structure(structure, 3.0)).plan(distance)
        assert all(ph.loads is not None for ph in plan.phases)
        peak = plan.peak_load
        assert 0.0 < peak.peak_force < geom.max_force and 0.0 < peak.holding_margin < 1.0
        assert peak.peak_force == max(ph.loads.peak_force for ph in plan.phases)
        for ph in plan.phases:
            if ph.timing is not None:
                assert ph.loads.peak_force == pytest.approx(np.abs(ph.timing.loads.actuator_forces).max())
                assert ph.duration == ph.timing.duration > 0.0
        rows = plan.rows()
        assert max(r['peak_force'] for r in rows if not np.isnan(r['peak_force'])) == peak.peak_force
        assert sum(r['duration'] for r in rows) == pytest.approx(plan.duration)
    # Without the check the same plan comes out, timed within the legs' limits, without figures.
    bare = GaitPlanner(geom, make_structure(structure, 3.0), loads=None).plan(distance)
    assert bare.peak_load is None and len(bare.phases) == len(plan.phases)
    assert bare.duration == pytest.approx(plan.duration, rel=0.05)


@pytest.mark.parametrize('speed', [0.0, -0.1, float('nan'), float('inf')])
def test_a_speed_that_is_not_finite_and_positive_is_refused_naming_the_step_and_phase(speed):
    with pytest.raises(PlanError) as err:
        GaitPlanner(load_robot('pole_climber'), make_structure('pole', 3.0), loads=LoadCheck(speed=speed)).plan(0.5)
    e = err.value
    assert e.limit is PlanLimit.SPEED and (e.step, e.phase) == (0, 'release_b')
    assert str(e).startswith(f'speed: {speed!r} m/s requested for step 0 release_b') and '\n' not in str(e)


@pytest.mark.parametrize('kwargs', [{'world_q_structure': (0, 0, 0, 2)}, {'gravity': (0.0, 9.81)}])
def test_bad_load_check_settings_are_a_value_error(kwargs):
    with pytest.raises(ValueError):
        LoadCheck(**kwargs)


def test_bringing_ring_b_back_to_the_gait_is_load_checked_too():
    geom = load_robot('pole_climber')
    planner = GaitPlanner(geom, make_structure('pole', 3.0))
    off = Pose(geom.home_position + [0.015, 0.0, 0.0], geom.home_quaternion_xyzw)
    phases = planner.approach(off, 0.2, 0.2 + geom.home_position[2])
    assert [ph.loads is not None for ph in phases] == [True, True, True]
    assert phases[1].timing is not None and phases[1].duration > 0.0
    heavy = GaitPlanner(geom.with_(payload=Payload(ring='ring_b', mass=200.0)), make_structure('pole', 3.0))
    with pytest.raises(PlanError) as err:
        heavy.approach(off, 0.2, 0.2 + geom.home_position[2])
    assert (err.value.limit, err.value.ring, err.value.phase) == (PlanLimit.HOLDING, 'ring_a', 'release_b')
