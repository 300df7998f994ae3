"""The statics kernel (rrps_loads.compiled_statics): one pose's numbers are those of the batch
(rrps_loads.loads), its actuator forces do the work of the potential energy (virtual work by
finite differences, written here from the robot description's parts), its support wrench
balances the whole robot and its holding margin is the gripper's model applied by hand to that
wrench, on either ring, at any attitude, with a payload and a tool wrench."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload, ToolWrench
from rrps_description.pose import Pose
from rrps_description.rotations import quat_multiply_xyzw, quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_loads.compiled_statics import grid_statics, pose_statics, statics_arrays
from rrps_loads.loads import static_solution
from rrps_loads.support import support_of

G = np.array([0.0, 0.0, -9.81])
ATTITUDES = {
    'upright': np.array([0.0, 0.0, 0.0, 1.0]),
    'wall': rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0])),
    'upside_down': rotation_vector_to_quat_xyzw(np.array([np.pi, 0.0, 0.0])),
    'tilt_45': rotation_vector_to_quat_xyzw(np.pi / 4 * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)),
}
ROBOTS = ['pole_climber', 'facade_climber', 'frame_climber']
CASES = [(r, s, a) for r in ROBOTS for s in ('ring_a', 'ring_b') for a in ATTITUDES]


def _loaded(name: str, wrench_frame: str = 'tool', torque=(1.5, -2.0, 0.5)):
    geom = load_robot(name)
    changes = {'payload': Payload(ring='ring_b', mass=6.0, com=np.array([0.05, -0.02, 0.08]))}
    if geom.tool is not None:
        changes['tool_wrench'] = ToolWrench(force=np.array([3.0, -4.0, 25.0]), torque=np.asarray(torque, dtype=float),
                                            frame=wrench_frame)
    return geom.with_(**changes)


def _pose(geom, dp=(0.03, -0.02, 0.04), rv=(0.05, -0.04, 0.08)):
    p = geom.home_position + geom.characteristic_length * np.asarray(dp)
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.asarray(rv, dtype=float)), geom.home_quaternion_xyzw)
    return p, q


def _kernel(geom, support, world_q, p, q):
    s = statics_arrays(geom, support_of(support, world_q))
    forces, wrench = np.empty(6), np.empty(6)
    margin = pose_statics(s, p, q, forces, wrench)
    return forces, wrench, margin


@pytest.mark.parametrize('robot,support,attitude', CASES)
@pytest.mark.parametrize('frame', ['tool', 'world'])
def test_the_kernel_gives_the_numbers_of_the_numpy_statics(robot, support, attitude, frame):
    geom = _loaded(robot, frame)
    p, q = _pose(geom)
    forces, wrench, margin = _kernel(geom, support, ATTITUDES[attitude], p, q)
    ref = static_solution(geom, Pose(p, q), support=support, world_q_support=ATTITUDES[attitude])
    scale = 9.81 * geom.total_mass
    np.testing.assert_allclose(forces, ref.actuator_forces, rtol=1e-9, atol=1e-9 * scale)
    np.testing.assert_allclose(wrench, ref.support_wrench, rtol=1e-9, atol=1e-9 * scale)
    if np.isnan(ref.holding_margin):
        assert np.isnan(margin)
    else:
        assert margin == pytest.approx(float(ref.holding_margin), rel=1e-9, abs=1e-9)
    # independently: the whole robot's balance, and the gripper's model by hand
    if frame == 'tool':
        np.testing.assert_allclose(wrench, _whole_robot_wrench(geom, support, ATTITUDES[attitude], p, q),
                                   atol=1e-9 * scale)
    capacity = geom.holding.get(support)
    if capacity is None:
        assert np.isnan(margin)
    else:
        assert margin == pytest.approx(_hand_margin(capacity, wrench), rel=1e-9, abs=1e-9)


def _hand_margin(c, w) -> float:
    """1 - the gripper's utilisation under the wrench w, from GripperCapacity's definitions."""
    force, moment = w[:3], w[3:] - np.cross(c.contact, w[:3])
    if c.kind == 'friction':
        return 1.0 - np.sqrt(force[2] ** 2 + (moment[2] / c.radius) ** 2) / (c.friction * c.clamp_force)
    return 1.0 - max(max(-force[2], 0.0) / c.axial_force, np.linalg.norm(force[:2]) / c.shear_force,
                     np.linalg.norm(moment) / c.torque)


def _potential(geom, p, q, support, world_q):
    """Gravity's and a constant tool force's potential, -Σ m g·x - F·x_tcp, of the robot with the
    supporting ring held at the origin, from the description's parts: rings, tool, payload, and
    each leg's two links at their coms along the leg (massless joints)."""
    R = quat_xyzw_to_matrix(q)
    if support == 'ring_a':
        Ra, ta, Rb, tb = np.eye(3), np.zeros(3), R, p
    else:
        Ra, ta, Rb, tb = R.T, -R.T @ p, np.eye(3), np.zeros(3)
    g = quat_xyzw_to_matrix(world_q).T @ G
    A = geom.ring_a_anchors @ Ra.T + ta
    B = geom.ring_b_anchors @ Rb.T + tb
    u = (B - A) / np.linalg.norm(B - A, axis=1)[:, None]
    masses = [(geom.ring_a_inertia.mass, Ra @ geom.ring_a_inertia.com + ta),
              (geom.ring_b_inertia.mass, Rb @ geom.ring_b_inertia.com + tb)]
    for i in range(6):
        masses.append((geom.lower_link.mass, A[i] + geom.lower_link.com_from_joint * u[i]))
        masses.append((geom.upper_link.mass, B[i] - geom.upper_link.com_from_joint * u[i]))
    V = 0.0
    if geom.tool is not None:
        tcp = Rb @ geom.tool.position + tb
        masses.append((geom.tool.mass, tcp + Rb @ quat_xyzw_to_matrix(geom.tool.quaternion_xyzw) @ geom.tool.com))
        if geom.tool_wrench is not None:     # a world-frame force, fixed in the supporting ring's frame
            V -= float(quat_xyzw_to_matrix(world_q).T @ geom.tool_wrench.force @ tcp)
    pay = geom.payload
    masses.append((pay.mass, (Ra, Rb)[pay.ring == 'ring_b'] @ pay.com + (ta, tb)[pay.ring == 'ring_b']))
    return V - sum(m * float(g @ x) for m, x in masses)


def _lengths(geom, p, q):
    R = quat_xyzw_to_matrix(q)
    return np.linalg.norm(p + geom.ring_b_anchors @ R.T - geom.ring_a_anchors, axis=1)


@pytest.mark.parametrize('robot,support,attitude', CASES)
def test_the_forces_do_the_virtual_work_of_the_potential_energy(robot, support, attitude):
    """Σ f_i δL_i = δV for every virtual motion of ring_b in ring_a (central differences of V
    and of the leg lengths, on three translations and three small rotations)."""
    geom = _loaded(robot, 'world', torque=(0.0, 0.0, 0.0))
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    forces, _, _ = _kernel(geom, support, world_q, p, q)
    h = 1e-5
    dV, dL = np.empty(6), np.empty((6, 6))
    for j, direction in enumerate(np.eye(6)):
        plus = (p + h * direction[:3], quat_multiply_xyzw(rotation_vector_to_quat_xyzw(h * direction[3:]), q))
        minus = (p - h * direction[:3], quat_multiply_xyzw(rotation_vector_to_quat_xyzw(-h * direction[3:]), q))
        dV[j] = (_potential(geom, *plus, support, world_q) - _potential(geom, *minus, support, world_q)) / (2 * h)
        dL[j] = (_lengths(geom, *plus) - _lengths(geom, *minus)) / (2 * h)
    np.testing.assert_allclose(np.linalg.solve(dL, dV), forces, rtol=1e-5, atol=1e-6 * 9.81 * geom.total_mass)


@pytest.mark.parametrize('robot,support,attitude', CASES)
def test_the_support_wrench_balances_the_whole_robot(robot, support, attitude):
    """The structure's wrench on the supporting ring against every weight and the tool wrench,
    summed over the parts in the supporting ring's frame (moments about its origin)."""
    geom = _loaded(robot, 'tool')
    p, q = _pose(geom)
    world_q = ATTITUDES[attitude]
    _, wrench, _ = _kernel(geom, support, world_q, p, q)
    np.testing.assert_allclose(wrench, _whole_robot_wrench(geom, support, world_q, p, q),
                               atol=1e-9 * 9.81 * geom.total_mass)


def _whole_robot_wrench(geom, support, world_q, p, q):
    """Minus every weight and the tool wrench (frame 'tool'), summed over the parts in the
    supporting ring's frame (moments about its origin)."""
    R = quat_xyzw_to_matrix(q)
    Rb, tb = (R, p) if support == 'ring_a' else (np.eye(3), np.zeros(3))
    Ra, ta = (np.eye(3), np.zeros(3)) if support == 'ring_a' else (R.T, -R.T @ p)
    g = quat_xyzw_to_matrix(world_q).T @ G
    A = geom.ring_a_anchors @ Ra.T + ta
    B = geom.ring_b_anchors @ Rb.T + tb
    u = (B - A) / np.linalg.norm(B - A, axis=1)[:, None]
    parts = [(geom.ring_a_inertia.mass, Ra @ geom.ring_a_inertia.com + ta),
             (geom.ring_b_inertia.mass, Rb @ geom.ring_b_inertia.com + tb),
             (geom.payload.mass, Rb @ geom.payload.com + tb)]
    parts += [(geom.lower_link.mass, A[i] + geom.lower_link.com_from_joint * u[i]) for i in range(6)]
    parts += [(geom.upper_link.mass, B[i] - geom.upper_link.com_from_joint * u[i]) for i in range(6)]
    force = sum(m * g for m, _ in parts)
    moment = sum(np.cross(x, m * g) for m, x in parts)
    if geom.tool is not None:
        R_tool = Rb @ quat_xyzw_to_matrix(geom.tool.quaternion_xyzw)
        tcp = Rb @ geom.tool.position + tb
        F, T = R_tool @ geom.tool_wrench.force, R_tool @ geom.tool_wrench.torque
        force = force + geom.tool.mass * g + F
        moment = moment + np.cross(tcp + R_tool @ geom.tool.com, geom.tool.mass * g) + np.cross(tcp, F) + T
    return -np.concatenate([force, moment])


def test_a_singular_pose_gives_nan_and_the_grid_kernel_reports_it():
    geom = load_robot('pole_climber')
    s = statics_arrays(geom, support_of('ring_a'))
    p, q = _pose(geom)
    forces, wrench = np.empty(6), np.empty(6)
    alike = geom.with_(ring_b_anchors=geom.ring_a_anchors.copy())   # both rings alike: parallel legs
    margin = pose_statics(statics_arrays(alike, support_of('ring_a')), np.array([0.0, 0.0, 0.5]),
                          np.array([0.0, 0.0, 0.0, 1.0]), forces, wrench)
    assert np.isnan(margin) and np.all(np.isnan(forces)) and np.all(np.isnan(wrench))
    points = np.stack([p, p + 0.01])
    out = np.empty((2, 2))
    grid_statics(s, points, q, geom.max_force, out)
    for n in range(2):
        ref = static_solution(geom, Pose(points[n], q))
        assert out[n, 0] == pytest.approx(np.abs(ref.actuator_forces).max() / geom.max_force, rel=1e-9)
        assert out[n, 1] == pytest.approx(float(ref.holding_margin), rel=1e-9)
