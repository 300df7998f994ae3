"""The demo scenarios: each names a robot and structure that exist, places ring_a in the world as the
climb node's odometry does, and gives each node only the parameters it declares."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_bringup.registry import registered_nodes
from rrps_bringup.scenarios import SCENARIOS, ros_arguments, scenario
from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_teleop.climbing.gait import GaitPlanner
from rrps_testing.virtual_work import rotation_x


@pytest.mark.parametrize('name', sorted(SCENARIOS))
def test_the_support_attitude_is_the_climb_nodes_odometry_of_ring_a(name):
    """The driver's world_q_support and the climb planner's world pose of ring_a (what the climb
    node publishes on odometry/ring_a and the viewer draws) are one attitude."""
    s = scenario(name)
    planner = GaitPlanner(load_robot(s.robot), s.structure_model())
    world_T_a, _ = planner.world_rings(0.5, 0.5 + planner.sep_home, 0.0, 0.0)
    np.testing.assert_allclose(quat_xyzw_to_matrix(s.support().world_q_support),
                               quat_xyzw_to_matrix(world_T_a.quaternion_xyzw), atol=1e-9)


def test_gravity_of_the_wall_and_of_the_leaning_trunk():
    """Built here: on the wall ring_a's z is the outward normal -y and its x the traverse +x; on the
    trunk ring_a is the upright frame turned 30 deg about x."""
    wall = np.column_stack([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    down = np.array([0.0, 0.0, -1.0])
    np.testing.assert_allclose(scenario('facade_wall').gravity_in_g(), wall.T @ down, atol=1e-9)
    np.testing.assert_allclose(scenario('facade_wall').gravity_in_g(), [0.0, -1.0, 0.0], atol=1e-9)
    trunk = rotation_x(math.radians(30.0))
    np.testing.assert_allclose(scenario('pole_leaning').gravity_in_g(), trunk.T @ down, atol=1e-9)
    np.testing.assert_allclose(scenario('pole_leaning').gravity_in_g(), [0.0, -0.5, -math.sqrt(3) / 2], atol=1e-9)


def test_each_node_gets_the_parameters_it_declares_and_no_others():
    nodes = registered_nodes()
    s = scenario('pole_leaning')
    driver = s.parameters('driver_node', nodes['driver_node'].parameters())
    assert driver['payload_mass'] == 40.0 and len(driver['world_q_support']) == 4
    assert 'structure' not in driver
    for node in ('climb_node', 'viewer_node', 'markers_node'):
        params = s.parameters(node, nodes[node].parameters())
        assert params['structure'] == 'pole' and params['structure_lean_deg'] == 30.0, node
        assert 'world_q_support' not in params and 'payload_mass' not in params, node
    assert s.parameters('ik_node', nodes['ik_node'].parameters()) == {'robot': 'pole_climber'}
    for name, node in nodes.items():  # every value passes the node's own schema
        schema = node.parameters()
        for key, value in s.parameters(name, schema).items():
            schema[key].check(value)


def test_ros_arguments_and_unknown_names():
    assert ros_arguments({'payload_mass': 15.0, 'structure': 'facade', 'world_q_support': (0.5, 0.5, 0.5, 0.5),
                          'flag': True}) == [
        '-p', 'payload_mass:=15.0', '-p', 'structure:=facade', '-p', 'world_q_support:=[0.5, 0.5, 0.5, 0.5]',
        '-p', 'flag:=true']
    with pytest.raises(ValueError, match='unknown scenario .*facade_wall'):
        scenario('bridge')
