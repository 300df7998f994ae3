"""Statics in the world (rrps_loads.statics, rrps_loads.loads): either ring gripping, at any
attitude, with payloads and a tool wrench; checked against computations written here from the
robot description alone (the free ring's Newton-Euler balance with massless legs, the world
gravity potential, the global balance of the whole robot, each leg's free body) and against the
multipliers of the 91-coordinate DAE at rest."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import GripperCapacity, Payload, ToolWrench
from rrps_description.pose import Pose
from rrps_description.robot_parts import LinkInertia
from rrps_description.rotations import quat_multiply_xyzw, quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics
from rrps_loads.loads import holding_margin, static_solution
from rrps_loads.statics import holding_forces
from rrps_sim.dynamics import MultibodyDynamics

G_WORLD = np.array([0.0, 0.0, -9.81])
ROBOTS = ['pole_climber', 'facade_climber', 'frame_climber']
SUPPORTS = ['ring_a', 'ring_b']
#: The supporting ring's attitude in the world: its normal (z) horizontal, pointing down, 45°.
ATTITUDES = {
    'wall': rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0])),
    'upside_down': rotation_vector_to_quat_xyzw(np.array([np.pi, 0.0, 0.0])),
    'tilt_45': rotation_vector_to_quat_xyzw(np.pi / 4 * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)),
}
SCENARIOS = [(r, s, a) for r in ROBOTS for s in SUPPORTS for a in ATTITUDES]
LIGHT = LinkInertia(mass=1e-9, com_from_joint=0.1, inertia_transverse=1e-12, inertia_axial=1e-12)


def _pose(geom, dp=(0.04, -0.03, 0.05), rv=(0.06, -0.04, 0.1)):
    p = geom.home_position + geom.characteristic_length * np.asarray(dp)
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.asarray(rv, dtype=float)), geom.home_quaternion_xyzw)
    return p, q


def _rings_in_support(p, q, support):
    """(R, t) of ring_a and ring_b in the supporting ring's frame."""
    R = quat_xyzw_to_matrix(q)
    if support == 'ring_a':
        return (np.eye(3), np.zeros(3)), (R, p)
    return (R.T, -R.T @ p), (np.eye(3), np.zeros(3))


def _external_loads(geom, p, q, support, world_q):
    """Every external load but the support's, in the supporting ring's frame, by body:
    {'ring_a': [...], 'ring_b': [...], 'links': [...]} of (force, point, torque), from the
    description's parts (rings, tool, payload, links, the tool wrench), gravity turned into the
    support's frame; and the joint centres A, B, the leg directions u and that gravity."""
    g = quat_xyzw_to_matrix(world_q).T @ G_WORLD
    (Ra, ta), (Rb, tb) = _rings_in_support(p, q, support)
    A = geom.ring_a_anchors @ Ra.T + ta
    B = geom.ring_b_anchors @ Rb.T + tb
    u = (B - A) / np.linalg.norm(B - A, axis=1)[:, None]
    zero = np.zeros(3)
    loads = {'ring_a': [(geom.ring_a_inertia.mass * g, Ra @ geom.ring_a_inertia.com + ta, zero)],
             'ring_b': [(geom.ring_b_inertia.mass * g, Rb @ geom.ring_b_inertia.com + tb, zero)],
             'links': []}
    for i in range(6):
        loads['links'].append((geom.lower_link.mass * g, A[i] + geom.lower_link.com_from_joint * u[i], zero))
        loads['links'].append((geom.upper_link.mass * g, B[i] - geom.upper_link.com_from_joint * u[i], zero))
    if geom.tool is not None:
        R_tool = Rb @ quat_xyzw_to_matrix(geom.tool.quaternion_xyzw)
        tcp = Rb @ geom.tool.position + tb
        loads['ring_b'].append((geom.tool.mass * g, tcp + R_tool @ geom.tool.com, zero))
        w = geom.tool_wrench
        if w is not None:
            R_w = R_tool if w.frame == 'tool' else quat_xyzw_to_matrix(world_q).T
            loads['ring_b'].append((R_w @ w.force, tcp, R_w @ w.torque))
    if geom.payload is not None:
        R, t = (Ra, ta) if geom.payload.ring == 'ring_a' else (Rb, tb)
        loads[geom.payload.ring].append((geom.payload.mass * g, R @ geom.payload.com + t, zero))
    return loads, A, B, u, g


def _all(loads):
    return loads['ring_a'] + loads['ring_b'] + loads['links']


def _wrench(loads):
    return np.concatenate([sum(f for f, _, _ in loads), sum(np.cross(x, f) + t for f, x, t in loads)])


def _potential(geom, p, q, support, world_q):
    """-Σ m g·x of the whole robot in the world, the supporting ring held at the origin."""
    loads, *_ = _external_loads(geom.with_(tool_wrench=None), p, q, support, world_q)
    return -sum(float(f @ x) for f, x, _ in _all(loads))


@pytest.mark.parametrize('robot,support,attitude', SCENARIOS)
def test_massless_legs_hold_the_free_ring_by_its_newton_euler_balance(robot, support, attitude):
    geom = load_robot(robot).with_(lower_link=LIGHT, upper_link=LIGHT)
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    loads, A, B, u, g = _external_loads(geom, p, q, support, world_q)
    # The free ring alone: its own loads and the actuators' pushes f_i u_i (on ring_b at B_i,
    # -f_i u_i on ring_a at A_i), balanced: [u; x × u] f = -W (6 x 6, from the leg vectors).
    free = loads['ring_b' if support == 'ring_a' else 'ring_a']
    sign, points = (1.0, B) if support == 'ring_a' else (-1.0, A)
    J = sign * np.concatenate([u.T, np.cross(points, u).T])
    expected = np.linalg.solve(J, -_wrench(free))
    got = holding_forces(geom, p, q, support=support, world_q_support=world_q)
    np.testing.assert_allclose(got, expected, atol=1e-6 * max(1.0, np.abs(expected).max()))


@pytest.mark.parametrize('robot,support,attitude', SCENARIOS)
def test_with_heavy_legs_the_forces_do_the_work_of_the_world_potential(robot, support, attitude):
    geom = load_robot(robot)
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    f = holding_forces(geom, p, q, support=support, world_q_support=world_q)
    h = 1e-5
    for direction in np.eye(6):
        steps = [(p + s * h * direction[:3], quat_multiply_xyzw(rotation_vector_to_quat_xyzw(s * h * direction[3:]), q))
                 for s in (1.0, -1.0)]
        dV = (_potential(geom, *steps[0], support, world_q) - _potential(geom, *steps[1], support, world_q)) / (2 * h)
        dl = (inverse_kinematics(geom, *steps[0]).lengths - inverse_kinematics(geom, *steps[1]).lengths) / (2 * h)
        assert f @ dl == pytest.approx(dV, abs=1e-7 * 9.81 * geom.total_mass)


@pytest.mark.parametrize('robot,support,attitude', SCENARIOS)
def test_agrees_with_the_multipliers_of_the_dae_at_rest(robot, support, attitude):
    geom = load_robot(robot)
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    sol = static_solution(geom, Pose(p, q), support=support, world_q_support=world_q)
    dyn = MultibodyDynamics(geom, support=support, world_q_support=world_q)
    np.testing.assert_allclose(dyn.holding_forces(p, q), sol.actuator_forces, atol=1e-6)
    dyn.reset(p, q)
    reactions = dyn.reactions(sol.actuator_forces)
    np.testing.assert_allclose(reactions.universal, sol.universal_reactions, atol=1e-6)
    np.testing.assert_allclose(reactions.spherical, sol.spherical_reactions, atol=1e-6)
    np.testing.assert_allclose(reactions.universal_torque, 0.0, atol=1e-6)   # none at rest


def _loaded(geom, tool_frame='tool'):
    geom = geom.with_(payload=Payload(ring='ring_b', mass=2.5, com=np.array([0.05, -0.12, 0.08])))
    if geom.tool is not None:
        geom = geom.with_(tool_wrench=ToolWrench(force=np.array([3.0, -8.0, 40.0]), torque=np.array([0.5, 1.5, -2.0]),
                                                 frame=tool_frame))
    return geom


@pytest.mark.parametrize('robot,support,attitude', SCENARIOS)
def test_the_support_balances_every_external_load(robot, support, attitude):
    geom = _loaded(load_robot(robot), 'world' if attitude == 'tilt_45' else 'tool')
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    sol = static_solution(geom, (p, q), support=support, world_q_support=world_q)
    loads, *_ = _external_loads(geom, p, q, support, world_q)
    total = _wrench(_all(loads))
    np.testing.assert_allclose(sol.support_wrench + total, 0.0, atol=1e-9 * np.abs(total).max())
    assert np.linalg.norm(total[:3]) > 100.0 and np.linalg.norm(total[3:]) > 1.0


@pytest.mark.parametrize('robot,support,attitude', SCENARIOS)
def test_each_leg_and_the_free_ring_balance_under_the_joint_reactions(robot, support, attitude):
    geom = _loaded(load_robot(robot))
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    sol = static_solution(geom, (p, q), support=support, world_q_support=world_q)
    loads, A, B, u, g = _external_loads(geom, p, q, support, world_q)
    lo, up = geom.lower_link, geom.upper_link
    RU, RS, f = sol.universal_reactions, sol.spherical_reactions, sol.actuator_forces
    L = np.linalg.norm(B - A, axis=1)
    scale = 9.81 * geom.total_mass
    for i in range(6):
        np.testing.assert_allclose(RU[i] + RS[i] + (lo.mass + up.mass) * g, 0.0, atol=1e-9 * scale)
        moment = (np.cross(B[i] - A[i], RS[i]) + np.cross(lo.com_from_joint * u[i], lo.mass * g)
                  + np.cross((L[i] - up.com_from_joint) * u[i], up.mass * g))
        np.testing.assert_allclose(moment, 0.0, atol=1e-9 * scale)
        # the upper link: ring_b's reaction, its weight and the actuator's push f u along the leg
        assert (RS[i] + up.mass * g) @ u[i] == pytest.approx(-f[i], abs=1e-9 * scale)
    # the free ring: what it carries and the legs' reactions on it at its joints
    free, on_free, at = ('ring_b', -RS, B) if support == 'ring_a' else ('ring_a', -RU, A)
    joints = [(on_free[i], at[i], np.zeros(3)) for i in range(6)]
    np.testing.assert_allclose(_wrench(loads[free] + joints), 0.0, atol=1e-9 * scale)


def test_a_load_on_the_supporting_ring_does_not_reach_the_actuators():
    geom = load_robot('pole_climber')
    p, q = _pose(geom)
    loaded = _loaded(geom)
    bare_b = static_solution(geom, (p, q), support='ring_b', world_q_support=ATTITUDES['wall'])
    loaded_b = static_solution(loaded, (p, q), support='ring_b', world_q_support=ATTITUDES['wall'])
    np.testing.assert_allclose(loaded_b.actuator_forces, bare_b.actuator_forces, atol=1e-9)
    assert np.abs(loaded_b.support_wrench - bare_b.support_wrench).max() > 20.0
    loaded_a = static_solution(loaded, (p, q), support='ring_a', world_q_support=ATTITUDES['wall'])
    bare_a = static_solution(geom, (p, q), support='ring_a', world_q_support=ATTITUDES['wall'])
    assert np.abs(loaded_a.actuator_forces - bare_a.actuator_forces).max() > 20.0
    # ... and the keyword overrides are the same as a robot that carries them
    again = static_solution(geom, (p, q), support='ring_a', world_q_support=ATTITUDES['wall'],
                            payload=loaded.payload, tool_wrench=loaded.tool_wrench)
    np.testing.assert_allclose(again.actuator_forces, loaded_a.actuator_forces, rtol=1e-12)


def test_the_facade_climber_on_a_wall_is_not_loaded_as_on_a_floor():
    geom = load_robot('facade_climber')
    p, q = geom.home_position, geom.home_quaternion_xyzw
    floor = holding_forces(geom, p, q)
    wall = holding_forces(geom, p, q, world_q_support=ATTITUDES['wall'])
    np.testing.assert_allclose(floor, floor.mean(), rtol=1e-3)           # about 18.33 N each
    assert np.abs(wall).max() > 5.0 * floor.max()                       # the weight levers out
    assert np.allclose(wall[[0, 1]], [-wall[1], -wall[0]], rtol=1e-9)    # mirrored pairs
    np.testing.assert_allclose(holding_forces(geom, p, q, gravity=[0.0, -9.81, 0.0]), wall, atol=1e-9)


def test_a_batch_of_poses_gives_what_single_poses_give():
    geom = load_robot('frame_climber')
    poses = [_pose(geom, (0.01 * k, -0.02, 0.03 * k), (0.05 * k, 0.02, -0.04)) for k in range(4)]
    P, Q = np.array([p for p, _ in poses]), np.array([q for _, q in poses])
    batch = static_solution(geom, (P, Q), support='ring_b', world_q_support=ATTITUDES['tilt_45'])
    assert batch.actuator_forces.shape == (4, 6) and batch.holding_margin.shape == (4,)
    for k, (p, q) in enumerate(poses):
        one = static_solution(geom, Pose(p, q), support='ring_b', world_q_support=ATTITUDES['tilt_45'])
        for name in ('actuator_forces', 'universal_reactions', 'spherical_reactions', 'support_wrench',
                     'holding_margin'):
            np.testing.assert_allclose(getattr(batch, name)[k], getattr(one, name), rtol=1e-12, atol=1e-10)


def test_holding_margins_of_the_two_gripper_models():
    clamp = GripperCapacity(clamp_force=1000.0, friction=0.5, radius=0.1)
    # 300 N along the member and 40 N m about it: √(300² + 400²) = 500 N of 500 N friction
    assert holding_margin(clamp, [50.0, -80.0, 300.0, 7.0, 9.0, 40.0]) == pytest.approx(0.0, abs=1e-12)
    assert holding_margin(clamp, [0.0, 0.0, 150.0, 0.0, 0.0, 0.0]) == pytest.approx(0.7)
    suction = GripperCapacity(axial_force=400.0, shear_force=300.0, torque=50.0, contact=np.array([0.0, 0.0, -0.5]))
    # pressing on the wall costs nothing; pulling 100 N off uses a quarter
    assert holding_margin(suction, [0.0, 0.0, 500.0, 0.0, 0.0, 0.0]) == pytest.approx(1.0)
    assert holding_margin(suction, [0.0, 0.0, -100.0, 0.0, 0.0, 0.0]) == pytest.approx(0.75)
    # 60 N of shear at the origin: 20 % of the shear, and 30 N m about the feet 0.5 m below: 60 %
    assert holding_margin(suction, [60.0, 0.0, 0.0, 0.0, 0.0, 0.0]) == pytest.approx(0.4)
    margins = holding_margin(suction, np.zeros((3, 4, 6)))
    assert margins.shape == (3, 4) and np.all(margins == 1.0)
    with pytest.raises(ValueError, match='wrench'):
        holding_margin(suction, [1.0, 2.0, 3.0])


def test_the_solution_carries_the_margin_of_the_supporting_gripper():
    geom = load_robot('pole_climber')
    sol = static_solution(geom, Pose(geom.home_position, geom.home_quaternion_xyzw))
    # upright on a pole the clamp's friction carries the whole weight: 1 - m g / (μ N)
    assert sol.holding_margin == pytest.approx(1.0 - 9.81 * geom.total_mass / (0.5 * 1500.0), rel=1e-9)
    bare = load_robot('master_robot')
    assert np.isnan(static_solution(bare, Pose(bare.home_position, bare.home_quaternion_xyzw)).holding_margin)


def test_invalid_worlds_are_refused():
    geom = load_robot('pole_climber')
    p, q = geom.home_position, geom.home_quaternion_xyzw
    with pytest.raises(ValueError, match="'ring_a' or 'ring_b'"):
        holding_forces(geom, p, q, support='ring_c')
    with pytest.raises(ValueError, match='world_q_support'):
        holding_forces(geom, p, q, world_q_support=[0.0, 0.0, 0.0, 2.0])
    with pytest.raises(ValueError, match='gravity'):
        holding_forces(geom, p, q, gravity=[0.0, np.nan, -9.81])
    with pytest.raises(ValueError, match='a_T_b'):
        static_solution(geom, 'home')
