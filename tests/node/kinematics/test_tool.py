"""A tool on ring_b (paper Figure 10): its description, its frame for IK and teleoperation,
and its mass in the moving platform the dynamics and statics see."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import RigidBodyInertia, RobotDescriptionError, RobotGeometry, combine_bodies, load_robot
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_description.tool import b_T_tool, ring_b_pose, tool_pose
from rrps_kinematics import inverse_kinematics
from rrps_teleop.mapping import TeleopConfig, TeleopMapping

POLE = load_robot('pole_climber')
MASTER = load_robot('master_robot')


def test_the_pole_climber_ships_with_a_maintenance_tool_on_an_arm():
    t = POLE.tool
    assert t is not None and t.mass > 0.0
    tcp = b_T_tool(POLE)
    radius = float(np.mean(np.linalg.norm(POLE.ring_b_anchors[:, :2], axis=1)))
    assert np.linalg.norm(tcp.position[:2]) > radius            # on an arm, beyond the ring
    body = POLE.ring_b_body
    assert body.mass == pytest.approx(POLE.ring_b_inertia.mass + t.mass)
    assert body.com[0] > POLE.ring_b_inertia.com[0]            # the arm shifts the platform's com
    assert load_robot('frame_climber').ring_b_body is load_robot('frame_climber').ring_b_inertia \
        or load_robot('frame_climber').tool is None


def test_combined_inertia_is_the_parallel_axis_sum():
    a = RigidBodyInertia(mass=2.0, com=np.zeros(3), inertia=np.diag([1.0, 1.0, 1.0]))
    b = RigidBodyInertia(mass=1.0, com=np.zeros(3), inertia=np.diag([0.1, 0.2, 0.3]))
    body = combine_bodies(a, b, np.eye(3), np.array([3.0, 0.0, 0.0]))
    np.testing.assert_allclose(body.com, [1.0, 0.0, 0.0])
    # about the new com: a at -1 m, b at +2 m along x
    np.testing.assert_allclose(body.inertia, np.diag([1.1, 1.2 + 2 * 1 + 1 * 4, 1.3 + 2 * 1 + 1 * 4]))


@pytest.mark.parametrize('change, key', [
    ({'mass': -1.0}, 'tool.mass'),
    ({'shape': 'cone'}, 'tool.shape'),
    ({'size': [0.1]}, 'tool.size'),
    ({'quaternion': [0, 0, 0, 2]}, 'tool.quaternion'),
    ({'inertia': [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, 'tool.inertia'),
])
def test_a_malformed_tool_names_its_key(tmp_path, change, key):
    import yaml

    from rrps_description.geometry import robot_path
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['tool'].update(change)
    path = tmp_path / 'robot.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(RobotDescriptionError, match=key):
        RobotGeometry.from_yaml(path)


poses = st.builds(lambda p, r: Pose(POLE.home_position + p, rotation_vector_to_quat_xyzw(r)),
                  st.lists(st.floats(-0.02, 0.02), min_size=3, max_size=3).map(np.array),
                  st.lists(st.floats(-0.1, 0.1), min_size=3, max_size=3).map(np.array))


@settings(max_examples=50, deadline=None)
@given(poses)
def test_tool_and_ring_b_frames_convert_both_ways(a_T_b):
    a_T_tool = tool_pose(POLE, a_T_b)
    back = ring_b_pose(POLE, a_T_tool)
    np.testing.assert_allclose(back.matrix, a_T_b.matrix, atol=1e-12)
    np.testing.assert_allclose(a_T_tool.matrix, a_T_b.matrix @ POLE.tool.b_T_tool, atol=1e-12)


def test_teleop_in_the_tool_frame_rotates_about_the_tool_tip():
    m = TeleopMapping(POLE, TeleopConfig(control_frame='tool', max_angular_speed=10.0,
                                         max_linear_speed=10.0))
    m.on_enable(0.0, True)
    m.on_master_pose(0.0, MASTER.home_position, MASTER.home_quaternion_xyzw)
    m.on_slave_pose(POLE.home_position, POLE.home_quaternion_xyzw)
    assert m.step(0.0).engaged
    tip0 = tool_pose(POLE, Pose(POLE.home_position, POLE.home_quaternion_xyzw)).position
    q = rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, 0.02]))   # the master turns 0.02 rad
    for k in range(1, 4):
        m.on_enable(0.05 * k, True)
        m.on_master_pose(0.05 * k, MASTER.home_position, q)
        out = m.step(0.05 * k)
    tip = tool_pose(POLE, Pose(out.position, out.quaternion_xyzw)).position
    np.testing.assert_allclose(tip, tip0, atol=1e-9)               # the tip stays put
    assert np.linalg.norm(out.position - POLE.home_position) > 1e-3  # ring_b swings about it
    with pytest.raises(ValueError, match='no tool'):
        TeleopMapping(load_robot('facade_climber'), TeleopConfig(control_frame='tool'))


@pytest.mark.ros
def test_ik_node_takes_targets_for_the_tool_tip(ros_context):
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState

    from rrps_kinematics.nodes.ik_node import IkNode
    from rrps_runtime.qos import COMMAND_QOS
    from rrps_testing.node_helpers import target
    from rrps_testing.ros_harness import Probe, Spinner, wait_for

    node = IkNode(context=ros_context, parameter_overrides=[Parameter('target_frame', value='tool')])
    probe = Probe(context=ros_context)
    commands = probe.collect(JointState, 'actuators/command', qos=COMMAND_QOS)
    targets = probe.publisher(PoseStamped, 'target_pose', command=True)
    a_T_b = Pose(POLE.home_position + [0.005, 0.0, 0.01], rotation_vector_to_quat_xyzw(np.array([0.0, 0.02, 0.0])))
    tip = tool_pose(POLE, a_T_b)
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: (targets.publish(target(probe, tip.position, tip.quaternion_xyzw)),
                                 commands)[1], 30.0, period=0.02)
    np.testing.assert_allclose(commands[-1].position,
                               inverse_kinematics(POLE, a_T_b.position, a_T_b.quaternion_xyzw).lengths,
                               atol=1e-12)
