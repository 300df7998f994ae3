"""Gravity belongs to the world (rrps_description.world), what a robot carries and what its
grippers hold to its description (rrps_description.loads): the YAML sections, the migration
error of a description that still gives gravity, and the ring bodies with their payload."""

import numpy as np
import pytest
import yaml

from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot, robot_path, shipped_robots
from rrps_description.loads import GripperCapacity, Payload, ToolWrench
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_description.world import STANDARD_GRAVITY, Support


def test_a_description_that_gives_gravity_says_how_to_migrate(tmp_path):
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['gravity'] = [0.0, 0.0, -9.81]
    path = tmp_path / 'old_robot.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(RobotDescriptionError) as info:
        RobotGeometry.from_yaml(path)
    message = str(info.value)
    assert message.startswith(f'{path}: gravity: a robot description no longer gives gravity, the world does')
    assert "Remove the 'gravity:' key" in message
    assert '--support ring_a|ring_b --support-quaternion QX,QY,QZ,QW' in message
    assert 'world_q_support=' in message
    with pytest.raises(TypeError):
        RobotGeometry(ring_a_anchors=data['ring_a']['anchors'], ring_b_anchors=data['ring_b']['anchors'],
                      gravity=[0.0, 0.0, -9.81])


@pytest.mark.parametrize('name', shipped_robots())
def test_shipped_robots_give_no_gravity_and_rate_their_grippers(name):
    assert 'gravity' not in yaml.safe_load(robot_path(name).read_text())
    g = load_robot(name)
    rated = {ring for ring, kind in g.grippers.items() if kind != 'none'}
    assert set(g.holding) == rated
    for capacity in g.holding.values():
        assert capacity.kind == ('friction' if g.grippers['ring_a'] == 'clamp' else 'limits')
    if name == 'facade_climber':        # ring_b's feet reach down to the wall
        assert g.holding['ring_b'].contact[2] == pytest.approx(-g.home_position[2], abs=1e-4)


def test_the_support_turns_the_worlds_gravity_into_its_frame():
    upright = Support.of()
    assert upright.ring == 'ring_a' and upright.index == 0
    np.testing.assert_array_equal(upright.gravity_in_support, STANDARD_GRAVITY)
    wall = Support.of('ring_b', [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)])    # normal horizontal
    assert wall.ring == 'ring_b' and wall.index == 1
    np.testing.assert_allclose(wall.gravity_in_support, [0.0, -9.81, 0.0], atol=1e-12)
    q = rotation_vector_to_quat_xyzw(np.array([0.3, -1.1, 0.7]))
    turned = Support.of('ring_a', q, gravity=[1.0, 2.0, -3.0])
    np.testing.assert_allclose(quat_xyzw_to_matrix(q) @ turned.gravity_in_support, [1.0, 2.0, -3.0])
    with pytest.raises(ValueError, match="support: must be 'ring_a' or 'ring_b'"):
        Support.of('ring_c')
    with pytest.raises(ValueError, match='world_q_support: quaternion norm 2 is not 1'):
        Support.of('ring_a', [0.0, 0.0, 0.0, 2.0])
    with pytest.raises(ValueError, match='gravity: expected 3 finite numbers'):
        Support.of('ring_a', None, [0.0, -9.81])


def test_the_optional_sections_load_and_load_the_rings(tmp_path):
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['payload'] = {'ring': 'ring_a', 'mass': 3.0, 'com': [0.1, 0.0, -0.05]}
    data['tool_wrench'] = {'force': [0.0, 0.0, 40.0], 'frame': 'tool'}
    data['ring_b']['holding'] = {'axial_force': 500.0, 'shear_force': 400.0, 'torque': 60.0,
                                 'contact': [0.0, 0.0, -0.1]}
    path = tmp_path / 'loaded.yaml'
    path.write_text(yaml.safe_dump(data))
    g = RobotGeometry.from_yaml(path)
    assert g.payload == Payload(ring='ring_a', mass=3.0, com=g.payload.com, inertia=g.payload.inertia)
    np.testing.assert_array_equal(g.tool_wrench.force, [0.0, 0.0, 40.0])
    assert g.tool_wrench.frame == 'tool' and g.holding['ring_b'].kind == 'limits'
    assert g.holding['ring_a'].kind == 'friction' and g.holding['ring_a'].clamp_force == 1500.0
    bare = load_robot('pole_climber')
    a = g.ring_a_body
    assert a.mass == pytest.approx(bare.ring_a_inertia.mass + 3.0)
    np.testing.assert_allclose(a.mass * a.com, 6.0 * bare.ring_a_inertia.com + 3.0 * np.array([0.1, 0.0, -0.05]))
    assert g.ring_b_body.mass == pytest.approx(bare.ring_b_body.mass)        # ring and tool
    assert g.total_mass == pytest.approx(bare.total_mass + 3.0)
    moved = g.with_(payload=Payload(ring='ring_b', mass=3.0, com=np.zeros(3)))
    assert moved.ring_b_body.mass == pytest.approx(bare.ring_b_body.mass + 3.0)
    assert moved.ring_a_body.mass == pytest.approx(bare.ring_a_inertia.mass)


def test_a_tool_wrench_needs_a_tool():
    g = load_robot('facade_climber')
    with pytest.raises(RobotDescriptionError, match='tool_wrench: acts at the tool-centre point'):
        g.with_(tool_wrench=ToolWrench(force=np.ones(3)))
    with pytest.raises(RobotDescriptionError, match='ring_c.holding'):
        g.with_(holding={'ring_c': GripperCapacity(axial_force=1.0, shear_force=1.0, torque=1.0)})
