"""The demo scenarios: each names a robot and structure that exist, places ring_a in the world as the
climb node's odometry does, and gives a node only the parameters its schema declares (the shipped
nodes' schemas: tests/node/bringup/test_scenario_parameters.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_bringup.scenarios import SCENARIOS, Scenario, ros_arguments, scenario
from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.gait import GaitPlanner
from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_runtime.parameter_schema import NodeParameters, Parameter
from rrps_testing.virtual_work import rotation_x


@pytest.mark.parametrize('name', sorted(SCENARIOS))
def test_the_support_attitude_is_the_climb_nodes_odometry_of_ring_a(name):
    """The driver's world_q_support and the climb planner's world pose of ring_a (what the climb
    node publishes on odometry/ring_a and the viewer draws) are one attitude; on a frame node,
    ring_a's at the crossing's start, both grippers side by side on the searched face."""
    s = scenario(name)
    if s.junction_deg > 0.0:
        planner = FrameNodePlanner(load_robot(s.robot), s.junction_deg)
        start = planner.crossing.candidate.s_pre
        world_T_a, _ = planner.world_rings(start, start, 0.0, 0.0)
    else:
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


def test_gravity_on_the_face_of_the_bent_frame():
    """Built here: the column stands vertical; ring_a's x runs up it and its z is the face normal
    -y (normal to both beams of the 90 deg bend in the x-z plane): gravity runs down ring_a's x."""
    face = np.column_stack([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    np.testing.assert_allclose(np.linalg.det(face), 1.0)
    np.testing.assert_allclose(scenario('frame_node').gravity_in_g(), face.T @ [0.0, 0.0, -1.0], atol=1e-9)
    assert scenario('frame_node').world_parameters()['junction_deg'] == 90.0
    with pytest.raises(ValueError, match='crosses no frame node'):
        scenario('facade_wall').crossing()


def test_a_node_gets_the_parameters_its_schema_declares_and_no_others():
    schema = NodeParameters('some_node', 'rrps_teleop', [
        Parameter('structure', 'pole', 'climbed structure'), Parameter('speed', 0.02, 'speed', unit='m/s')])
    row = Scenario('frame_node', robot='frame_climber', structure='frame', summary='across a node',
                   motion='ring_b along the column', handle_step=(0.0, 0.0, 0.004), payload_mass=5.0,
                   node_parameters=(('speed', 0.08),))
    assert row.parameters('some_node', schema) == {'structure': 'frame', 'speed': 0.08}
    assert row.parameters('unknown_node', None) == {}


def test_ros_arguments_and_unknown_names():
    assert ros_arguments({'payload_mass': 15.0, 'structure': 'facade', 'world_q_support': (0.5, 0.5, 0.5, 0.5),
                          'flag': True}) == [
        '-p', 'payload_mass:=15.0', '-p', 'structure:=facade', '-p', 'world_q_support:=[0.5, 0.5, 0.5, 0.5]',
        '-p', 'flag:=true']
    with pytest.raises(ValueError, match='unknown scenario .*facade_wall'):
        scenario('bridge')


def test_the_demos_help_names_every_scenario():
    """``./rrps demo --help`` reads the names from the standard-library module, before any install."""
    from rrps_bringup.demo_arguments import SCENARIO_NAMES, demo_parser
    assert SCENARIO_NAMES == tuple(SCENARIOS)
    assert ' | '.join(SCENARIOS) in ' '.join(demo_parser().format_help().split())
