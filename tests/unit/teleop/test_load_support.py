"""Teleop's load guards on the ring that carries the robot (rrps_teleop.load_support): the
support starts as the parameters give it, takes the odometry's attitude, and switches ring with
the grippers; the guards' forces are those of virtual work written independently
(rrps_testing.virtual_work) in the world's gravity turned by the test's own rotations, and a
motion that ring_a's gripper allows halts once ring_b's weaker gripper carries the robot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import GripperCapacity, Payload
from rrps_description.pose import Pose
from rrps_description.world import Support
from rrps_interfaces.driver import SupportSource
from rrps_interfaces.teleop import TeleopCode
from rrps_kinematics.backend import use_numba
from rrps_loads.loads import static_solution
from rrps_teleop.load_support import LoadSupport
from rrps_teleop.mapping import TeleopConfig, TeleopMapping
from rrps_testing.virtual_work import quaternion_matrix, rotation_x, virtual_work_forces

BACKENDS = pytest.mark.parametrize('backend', (['numba'] if use_numba('auto') else []) + ['numpy'])
G = np.array([0.0, 0.0, -9.81])
LEAN = math.radians(30.0)        # the pole leans 30 deg about the world x axis
Q_LEAN = (math.sin(LEAN / 2), 0.0, 0.0, math.cos(LEAN / 2))
PLAIN = load_robot('pole_climber')  # virtual work takes the payload as an argument
BASE = PLAIN.with_(payload=Payload(ring='ring_b', mass=40.0, com=np.zeros(3)))
BOTH, B_ONLY = {'ring_a': True, 'ring_b': True}, {'ring_a': False, 'ring_b': True}
DT = 0.01


@BACKENDS
def test_the_guards_follow_the_odometry_and_the_carrying_ring(backend):
    g = BASE
    mapping = TeleopMapping(g, backend=backend)                    # the parameters: ring_a upright
    support = LoadSupport(mapping.loads)
    p, q = g.home_position, g.home_quaternion_xyzw
    R = quaternion_matrix(q)
    support.on_slave_pose(q)
    assert support.report(0.0).source is SupportSource.PARAMETERS
    upright = virtual_work_forces(PLAIN, p, R, G, payload_mass=40.0)
    np.testing.assert_allclose(mapping.loads.margins_at(p, q).forces, upright, rtol=1e-5, atol=1e-3)

    assert support.on_odometry('world', 'ring_a', Q_LEAN, 0.1)   # the odometry: ring_a on the leaning pole
    leaning = virtual_work_forces(PLAIN, p, R, rotation_x(LEAN).T @ G, payload_mass=40.0)
    np.testing.assert_allclose(mapping.loads.margins_at(p, q).forces, leaning, rtol=1e-5, atol=1e-3)
    assert not np.allclose(leaning, upright, atol=1.0)
    assert support.report(0.2).source is SupportSource.ODOMETRY

    assert support.on_grippers(B_ONLY, 0.3).ring == 'ring_b'      # ring_a opened: ring_b carries
    world_R_b = rotation_x(LEAN) @ R
    on_b = virtual_work_forces(PLAIN, p, R, world_R_b.T @ G, support='ring_b', payload_mass=40.0)
    np.testing.assert_allclose(mapping.loads.margins_at(p, q).forces, on_b, rtol=1e-5, atol=1e-3)
    assert support.report(0.3).source is SupportSource.HANDED_OVER
    # the odometry of ring_b (here turned a little further) replaces the hand-over
    turned = rotation_x(LEAN + 0.1) @ R
    q_b = Pose.from_matrix(np.block([[turned, np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]))
    assert support.on_odometry('world', 'ring_b', q_b.quaternion_xyzw, 0.4)
    on_b = virtual_work_forces(PLAIN, p, R, turned.T @ G, support='ring_b', payload_mass=40.0)
    np.testing.assert_allclose(mapping.loads.margins_at(p, q).forces, on_b, rtol=1e-5, atol=1e-3)
    assert support.on_grippers(BOTH, 0.5).ring == 'ring_a'        # ring_a closed again: it carries,
    # handed back through the same a_T_b: turned as ring_b's odometry said
    np.testing.assert_allclose(mapping.loads.support.gravity_in_support, rotation_x(LEAN + 0.1).T @ G, atol=1e-9)
    # the odometry silent: the last attitude stays
    assert support.report(5.0).stale and support.on_grippers(BOTH, 5.0) is None


def _weak_ring_b(margin: float):
    """ring_b's clamp so weak that its holding margin at home, carrying the robot on the leaning
    pole, is ``margin``; ring_a's is the robot's. The direction that lowers it."""
    q_b = Pose.from_matrix(np.block([[rotation_x(LEAN) @ quaternion_matrix(BASE.home_quaternion_xyzw),
                                      np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]])).quaternion_xyzw
    on_b = Support.of('ring_b', q_b)
    clamp = GripperCapacity(clamp_force=1500.0, friction=0.5, radius=0.1)
    geom = BASE.with_(holding={'ring_a': clamp, 'ring_b': clamp})
    p, q = geom.home_position, geom.home_quaternion_xyzw

    def holding(g, x):
        return float(static_solution(g, Pose(x, q), support=on_b).holding_margin)
    used = 1.0 - holding(geom, p)
    weak = GripperCapacity(clamp_force=1500.0 * used / (1.0 - margin), friction=0.5, radius=0.1)
    geom = geom.with_(holding={'ring_a': clamp, 'ring_b': weak})
    h = 1e-4
    grad = np.array([(holding(geom, p + h * e) - holding(geom, p - h * e)) / (2 * h) for e in np.eye(3)])
    return geom, -grad / np.linalg.norm(grad)


@BACKENDS
def test_a_motion_ring_a_allows_halts_once_ring_b_carries(backend):
    geom, towards = _weak_ring_b(-0.02)
    config = TeleopConfig()
    mapping = TeleopMapping(geom, config, backend=backend)
    support = LoadSupport(mapping.loads)
    p0, q0 = geom.home_position, geom.home_quaternion_xyzw
    mapping.on_slave_pose(p0, q0)
    support.on_slave_pose(q0)
    support.on_odometry('world', 'ring_a', Q_LEAN, 0.0)
    support.on_grippers(BOTH, 0.0)
    outs, positions = [], [p0]
    for k in range(60):
        t = k * DT
        if k == 30:                                               # ring_a opens: ring_b carries now
            assert support.on_grippers(B_ONLY, t).ring == 'ring_b'
        mapping.on_enable(t, True)
        mapping.on_master_pose(t, towards * config.max_linear_speed * t / config.translation_scale,
                               np.array([0.0, 0.0, 0.0, 1.0]))
        out = mapping.step(t)
        outs.append(out)
        if out.has_command:
            positions.append(out.position)
            mapping.on_slave_pose(out.position, out.quaternion_xyzw)
            support.on_slave_pose(out.quaternion_xyzw)
    assert {o.code for o in outs[1:30]} <= {TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED}
    moved = np.linalg.norm(positions[-1] - p0) if len(positions) > 1 else 0.0
    assert moved > 0.01                                               # ring_a's gripper let it go
    assert outs[-1].code is TeleopCode.HALT_FOR_HOLDING
    # the margins the guards reported: ring_a's clamp before (far from its limit), ring_b's after
    assert min(o.margins['holding'] for o in outs[1:30]) > 0.2
    assert all(-0.03 < o.margins['holding'] < 0.0 for o in outs[31:])
    held = [o for o in outs[31:] if o.has_command]
    assert not held or np.linalg.norm(held[-1].position - outs[29].position) < 1e-6   # no further in
