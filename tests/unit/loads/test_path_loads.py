"""Loads along a timed path (rrps_loads.path_loads), checked against computations written here
from the robot description alone: the moving ring's motion given in closed form (its velocities
and accelerations differentiated by hand, not from samples), virtual work with a finite-difference
Jacobian of the six leg lengths with respect to that ring's pose, the whole robot's momentum
balance for the holding ring's reaction, and, at rest with heavy legs, the world gravity
potential. (Points of real climbing plans: tests/unit/teleop/test_load_check.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.robot_parts import LinkInertia
from rrps_description.rotations import (
    matrix_to_quat_xyzw,
    quat_xyzw_to_matrix,
    rotation_vector_to_matrix,
    rotation_vector_to_quat_xyzw,
)
from rrps_loads.loads import holding_margin
from rrps_loads.path_loads import ACTUATOR_FORCE, HOLDING, first_violation, loads_at, path_loads
from rrps_testing.virtual_work import moving_ring_dynamics

G_WORLD = np.array([0.0, 0.0, -9.81])
LIGHT = LinkInertia(mass=1e-9, com_from_joint=0.1, inertia_transverse=1e-12, inertia_axial=1e-12)
#: The holding ring's attitude in the world: on a wall, and tilted 45° about a horizontal axis.
WALL = rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0]))
TILT = rotation_vector_to_quat_xyzw(np.pi / 4 * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0))
CASES = [(robot, support, q) for robot in ('pole_climber', 'facade_climber')
         for support in ('ring_a', 'ring_b') for q in (WALL, TILT)]
#: The moving ring's motion in the holding ring's frame: an offset d sin(w t) and a turn
#: theta0 sin(w t) about a fixed axis, from the home pose.
W, D, THETA0 = 4.0, np.array([0.02, -0.015, 0.01]), 0.08
AXIS = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])


def _home_in_support(geom, support):
    R = quat_xyzw_to_matrix(geom.home_quaternion_xyzw)
    p = geom.home_position
    return (R, p) if support == 'ring_a' else (R.T, -R.T @ p)


def _motion(geom, support, t):
    """The moving ring's pose (R, p) and its origin's velocity and acceleration, angular
    velocity and acceleration at time t, in the holding ring's frame (closed form)."""
    R0, p0 = _home_in_support(geom, support)
    s, c = np.sin(W * t), np.cos(W * t)
    R = rotation_vector_to_matrix(THETA0 * s * AXIS) @ R0
    return (R, p0 + D * s, D * W * c, -D * W**2 * s, THETA0 * W * c * AXIS, -THETA0 * W**2 * s * AXIS)


def _samples(geom, support, t):
    """The path as path_loads takes it: a_T_b at each time."""
    poses = []
    for tk in t:
        R, p = _motion(geom, support, tk)[:2]
        if support == 'ring_b':                       # the motion is ring_a's in ring_b: invert
            R, p = R.T, -R.T @ p
        poses.append((p, matrix_to_quat_xyzw(R)))
    return np.array([p for p, _ in poses]), np.array([q for _, q in poses])


def _newton_euler(geom, support, world_q, t):
    """Forces (6,) and the structure's wrench on the holding ring (6,) at time t, massless legs
    (rrps_testing.virtual_work: virtual work and momentum balance)."""
    moving = geom.ring_b_body if support == 'ring_a' else geom.ring_a_body
    R, p, v, a, omega, alpha = _motion(geom, support, t)
    com = R @ moving.com
    a_c = a + np.cross(alpha, com) + np.cross(omega, np.cross(omega, com))
    return moving_ring_dynamics(geom, support, quat_xyzw_to_matrix(world_q).T @ G_WORLD, R, p, omega, alpha, a_c)


@pytest.mark.parametrize('robot,support,world_q', CASES)
def test_moving_forces_and_reaction_match_newton_euler_by_virtual_work(robot, support, world_q):
    geom = load_robot(robot).with_(lower_link=LIGHT, upper_link=LIGHT, tool=None,
                                   payload=Payload(ring='ring_b', mass=20.0, com=np.array([0.05, 0.0, 0.1])))
    t = np.linspace(0.0, 1.5, 301)
    p, q = _samples(geom, support, t)
    loads = path_loads(geom, t, p, q, support=support, world_q_support=world_q)
    inertial = 0.0
    for k in (20, 120, 200, 280):
        f, wrench = _newton_euler(geom, support, world_q, t[k])
        scale = np.abs(f).max()
        np.testing.assert_allclose(loads.actuator_forces[k], f, atol=1e-6 * scale)
        np.testing.assert_allclose(loads.support_wrench[k], wrench, atol=1e-6 * np.abs(wrench).max())
        assert loads.holding_margin[k] == pytest.approx(holding_margin(geom.holding[support], wrench), abs=1e-8)
        at_rest = path_loads(geom, [0.0], p[k], q[k], support=support, world_q_support=world_q)
        inertial = max(inertial, np.abs(loads.actuator_forces[k] - at_rest.actuator_forces[0]).max() / scale)
    assert inertial > 0.02     # the motion's accelerations are a real part of the forces


def _potential(geom, support, world_q, R, p):
    """-Σ m g·x of the moving ring and the twelve leg links (coms on the leg lines), the moving
    ring at (R, p) in the holding ring's frame."""
    g = quat_xyzw_to_matrix(world_q).T @ G_WORLD
    moving = geom.ring_b_body if support == 'ring_a' else geom.ring_a_body
    local, fixed = ((geom.ring_b_anchors, geom.ring_a_anchors) if support == 'ring_a'
                    else (geom.ring_a_anchors, geom.ring_b_anchors))
    X = local @ R.T + p
    A, B = (fixed, X) if support == 'ring_a' else (X, fixed)
    u = (B - A) / np.linalg.norm(B - A, axis=1)[:, None]
    lower = A + geom.lower_link.com_from_joint * u
    upper = B - geom.upper_link.com_from_joint * u
    return -(moving.mass * g @ (R @ moving.com + p) + geom.lower_link.mass * np.sum(lower @ g)
             + geom.upper_link.mass * np.sum(upper @ g))


@pytest.mark.parametrize('robot,support,world_q', CASES)
def test_at_rest_with_heavy_legs_the_forces_do_the_work_of_the_potential(robot, support, world_q):
    geom = load_robot(robot).with_(tool=None)
    p, q = _samples(geom, support, [0.3])
    loads = path_loads(geom, [0.0], p, q, support=support, world_q_support=world_q)
    R, pos = _motion(geom, support, 0.3)[:2]
    local, fixed = ((geom.ring_b_anchors, geom.ring_a_anchors) if support == 'ring_a'
                    else (geom.ring_a_anchors, geom.ring_b_anchors))
    h = 1e-6

    def moved(x):                                    # the moving ring's origin by x[:3], turned by x[3:]
        return rotation_vector_to_matrix(x[3:]) @ R, pos + x[:3]

    def lengths(x):
        Rx, px = moved(x)
        return np.linalg.norm(local @ Rx.T + px - fixed, axis=1)

    J = np.column_stack([(lengths(h * e) - lengths(-h * e)) / (2 * h) for e in np.eye(6)])
    dV = np.array([(_potential(geom, support, world_q, *moved(h * e))
                    - _potential(geom, support, world_q, *moved(-h * e))) / (2 * h) for e in np.eye(6)])
    f = np.linalg.solve(J.T, dV)                     # Σ f δL = δV at rest
    np.testing.assert_allclose(loads.actuator_forces[0], f, atol=1e-5 * np.abs(f).max())
    # At rest the structure carries the whole robot's weight.
    assert loads.support_wrench[0, :3] == pytest.approx(
        -(quat_xyzw_to_matrix(world_q).T @ G_WORLD) * geom.total_mass, abs=1e-6)


def test_first_violation_names_the_leg_or_the_ring():
    geom = load_robot('pole_climber')
    p, q = _samples(geom, 'ring_a', np.linspace(0.0, 1.5, 31))
    loads = path_loads(geom, np.linspace(0.0, 1.5, 31), p, q)
    assert first_violation(geom, loads) is None
    peak = np.abs(loads.actuator_forces).max()
    k = np.unravel_index(np.argmax(np.abs(loads.actuator_forces) > 0.9 * peak), loads.actuator_forces.shape)[0]
    v = first_violation(geom.with_(max_force=0.9 * peak), loads)
    assert (v.limit, v.sample, v.who) == (ACTUATOR_FORCE, k, f'leg_{np.argmax(np.abs(loads.actuator_forces[k])) + 1}')
    assert abs(v.value) > v.bound == pytest.approx(0.9 * peak)
    heavy = geom.with_(payload=Payload(ring='ring_b', mass=200.0))
    v = first_violation(heavy, path_loads(heavy, [0.0], p[0], q[0]))
    assert (v.limit, v.sample, v.who) == (HOLDING, 0, 'ring_a') and v.value < 0.0


@pytest.mark.parametrize('t,p,q', [
    (np.arange(5.0), np.zeros((4, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))),
    (np.arange(2.0), np.zeros((1, 3)), [[0.0, 0.0, 0.0, 1.0]]),
    (np.zeros(5), np.zeros((5, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))),
    ([0.0], [[0.0, 0.0, np.nan]], [[0.0, 0.0, 0.0, 1.0]]),
])
def test_bad_paths_are_a_value_error(t, p, q):
    geom = load_robot('pole_climber')
    with pytest.raises(ValueError):
        path_loads(geom, t, np.asarray(p) + geom.home_position, q)


@pytest.mark.parametrize('twist', [np.zeros((2, 6)), np.full((3, 6), np.nan)])
def test_bad_twists_are_a_value_error(twist):
    geom = load_robot('pole_climber')
    p, q = _samples(geom, 'ring_a', [0.0, 0.1, 0.2])
    with pytest.raises(ValueError):
        loads_at(geom, p, q, twist, np.zeros((3, 6)))
