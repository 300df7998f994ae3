"""The simulated hardware in the world: its efforts hold the robot in the gravity of ring_a's attitude
(``world_q_support``) with the payload of its parameters, checked by virtual work written
independently (rrps_testing.virtual_work), and the support follows the grippers."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_description.world import Support, handed_over
from rrps_hardware.interface import HardwareConfig
from rrps_sim.simulated_robot import SimulatedRobot
from rrps_testing.virtual_work import quaternion_matrix, virtual_work_forces

WALL_Q = (0.70710678118654752, 0.0, 0.0, 0.70710678118654752)  # ring_a's z horizontal, out of a wall


def _robot(geometry, **parameters) -> SimulatedRobot:
    robot = SimulatedRobot()
    outcome = robot.on_configure(HardwareConfig(geometry, {'time_constant': 0.0, **parameters}))
    assert outcome.ok, outcome.reason
    return robot


def test_virtual_work_here_balances_a_weight_on_massless_legs():
    """The independent statics on a case with a known answer: the legs' pull on ring_b balances
    the weight of ring_b and its payload along every axis; with ring_b gripping, the same forces
    hold ring_a in the gravity of ring_b's frame turned (the leg forces do not care which end is fixed)."""
    g = load_robot('pole_climber')
    R = quaternion_matrix(g.home_quaternion_xyzw)
    forces = virtual_work_forces(g, g.home_position, R, [0.0, -9.81, 0.0], payload_mass=10.0, legs=False)
    tips = g.home_position + g.ring_b_anchors @ R.T
    u = (tips - g.ring_a_anchors) / np.linalg.norm(tips - g.ring_a_anchors, axis=1)[:, None]
    np.testing.assert_allclose((u * forces[:, None]).sum(axis=0), [0.0, (g.ring_b_body.mass + 10.0) * 9.81, 0.0],
                               atol=1e-4)
    # ring_a hung from ring_b: the legs' push on ring_a, -sum(f u), balances its weight
    up_b = R.T @ [0.0, 0.0, -9.81]  # gravity along ring_a's -z, seen in ring_b's frame
    flipped = virtual_work_forces(g, g.home_position, R, up_b, support='ring_b', legs=False)
    np.testing.assert_allclose(-(u * flipped[:, None]).sum(axis=0), [0.0, 0.0, g.ring_a_body.mass * 9.81],
                               atol=1e-4)


@pytest.mark.parametrize('robot, q, payload', [('facade_climber', WALL_Q, 15.0),
                                               ('pole_climber', (0.25881904510252074, 0.0, 0.0, 0.9659258262890683),
                                                40.0)])
def test_the_efforts_hold_the_robot_in_the_world_with_its_payload(robot, q, payload):
    g = load_robot(robot)
    sim = _robot(g, world_q_support=q, payload_mass=payload)
    expected = virtual_work_forces(g, g.home_position, quaternion_matrix(g.home_quaternion_xyzw),
                                   quaternion_matrix(q).T @ [0.0, 0.0, -9.81], payload_mass=payload)
    np.testing.assert_allclose(sim.read(0.0, 0.01).efforts, expected, rtol=1e-5, atol=1e-3)
    upright = _robot(g)  # the default: ring_a upright, the description's payload (none)
    assert not np.allclose(upright.read(0.0, 0.01).efforts, expected, atol=1.0)


def test_the_support_is_handed_over_with_the_grippers():
    g = load_robot('pole_climber')
    sim = _robot(g, world_q_support=WALL_Q)
    assert sim.on_activate().ok
    sim.write(0.0, 0.01, None)
    assert sim.set_gripper('ring_a', False).ok
    opening = g.motion_limits.grippers['ring_a'].open
    sim.write(0.5 * opening, 0.01, None)
    assert sim.support.ring == 'ring_a'  # still opening: ring_a's sensor reads closed
    sim.write(opening, 0.01, None)
    assert sim.support.ring == 'ring_b'
    # ring_b's attitude is ring_a's turned by a_R_b (the home pose's rotation)
    world_R_b = quaternion_matrix(WALL_Q) @ quaternion_matrix(g.home_quaternion_xyzw)
    np.testing.assert_allclose(quat_xyzw_to_matrix(sim.support.world_q_support), world_R_b, atol=1e-9)
    np.testing.assert_allclose(sim.support.gravity_in_support, world_R_b.T @ [0.0, 0.0, -9.81], atol=1e-9)
    # its efforts: ring_a, the legs and nothing else hang from ring_b now (virtual work, ring_b fixed)
    sim.write(opening + 1.0, 1.0, None)  # past the efforts' refresh period
    expected = virtual_work_forces(g, g.home_position, quaternion_matrix(g.home_quaternion_xyzw),
                                   world_R_b.T @ [0.0, 0.0, -9.81], support='ring_b')
    np.testing.assert_allclose(sim.read(1.0, 0.01).efforts, expected, rtol=1e-5, atol=1e-3)
    assert sim.set_gripper('ring_a', True).ok
    sim.write(opening + 1.0 + g.motion_limits.grippers['ring_a'].close, 0.01, None)
    assert sim.support.ring == 'ring_a'
    np.testing.assert_allclose(quat_xyzw_to_matrix(sim.support.world_q_support), quaternion_matrix(WALL_Q),
                               atol=1e-9)


def test_hand_over_there_and_back_and_bad_parameters():
    a = Support.of('ring_a', WALL_Q)
    a_q_b = np.array([0.1, -0.2, 0.05, 1.0]) / np.linalg.norm([0.1, -0.2, 0.05, 1.0])
    assert handed_over(a, a_q_b, 'ring_a') is a
    back = handed_over(handed_over(a, a_q_b, 'ring_b'), a_q_b, 'ring_a')
    np.testing.assert_allclose(quat_xyzw_to_matrix(back.world_q_support), quat_xyzw_to_matrix(a.world_q_support),
                               atol=1e-12)
    for parameters, reason in (({'world_q_support': (0.0, 0.0, 0.0, 2.0)}, 'world_q_support'),
                               ({'payload_mass': 5.0, 'payload_com': (0.0, 0.0)}, 'payload_com')):
        outcome = SimulatedRobot().on_configure(HardwareConfig(load_robot('pole_climber'), parameters))
        assert not outcome.ok and reason in outcome.reason
