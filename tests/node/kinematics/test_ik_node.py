"""ik_node in-process: target_pose -> actuators/command, every rejection path, velocity limiting."""

import numpy as np
import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot, robot_path
from rrps_description.names import LEG_NAMES
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics, margins
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_runtime.messages import joint_state_msg
from rrps_runtime.qos import COMMAND_QOS
from rrps_testing.node_helpers import said, target
from rrps_testing.ros_harness import Probe, Spinner, header_time, wait_for

POLE = load_robot('pole_climber')

pytestmark = pytest.mark.ros


@pytest.fixture
def relaxed_robot(tmp_path):
    """pole_climber with unlimited joint angles and a long stroke, as a YAML path: it can reach
    poses that only interference or only conditioning forbids."""
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['legs'].update(universal_max_angle=3.14, spherical_max_angle=3.14, min_length=0.05, max_length=1.0)
    path = tmp_path / 'relaxed.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


def only_violation(geometry, position, rotation_vector, kind):
    """The pose as (position, quaternion), asserting that ``kind`` is its only violated limit."""
    q = rotation_vector_to_quat_xyzw(np.asarray(rotation_vector))
    minimum = margins(geometry, inverse_kinematics(geometry, position, q)).minimum
    assert minimum[kind] < 0 and all(v >= 0 for k, v in minimum.items() if k != kind), minimum
    return position, q


def test_valid_target_is_published_as_ik_lengths(ros_context):
    node = IkNode(context=ros_context, namespace='/t')
    probe = Probe(context=ros_context, namespace='/t')
    commands = probe.collect(JointState, 'actuators/command', qos=COMMAND_QOS)
    pub = probe.publisher(PoseStamped, 'target_pose', command=True)
    p = POLE.home_position + [0.01, -0.02, 0.015]
    q = rotation_vector_to_quat_xyzw(np.array([0.05, -0.02, 0.1]))
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        sent = []
        assert wait_for(lambda: (sent.append(target(probe, p, q)), pub.publish(sent[-1]), commands)[2], period=0.01)
    out = commands[0]
    assert list(out.name) == list(LEG_NAMES)
    assert out.header.stamp in [m.header.stamp for m in sent]  # the target's age travels with the command
    np.testing.assert_allclose(out.position, inverse_kinematics(POLE, p, q).lengths, rtol=0, atol=1e-12)


def test_every_rejection_keeps_the_last_command_and_says_why(ros_context, relaxed_robot):
    relaxed = RobotGeometry.from_yaml(relaxed_robot)
    pole = IkNode(context=ros_context, namespace='/pole')
    loose = IkNode(context=ros_context, namespace='/loose',
                   parameter_overrides=[Parameter('robot', value=str(relaxed_robot))])
    probe = Probe(context=ros_context)
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    home = POLE.home_position
    cases = [  # (node, target kwargs, text the diagnostic must contain)
        (pole, dict(position=[0.0, np.nan, 0.42]), 'NaN'),
        (pole, dict(position=home, frame_id='world'), "frame_id is 'world'"),
        (pole, dict(position=home, quaternion_xyzw=[0.0, 0.0, 0.1, 0.9]), 'quaternion norm'),
        (pole, dict(position=home + [0.0, 0.0, 0.3]), 'stroke: leg_1'),
        (pole, dict(position=home, age=0.5), 'stale'),
    ]
    for kind, p, r, node in (
            ('universal', [0.02695531, 0.13402332, 0.37459878], [-0.31231082, -0.15920842, -0.68198905], pole),
            ('spherical', [-0.04483356, -0.09869357, 0.37151278], [-0.50687316, -0.12174385, -0.09734391], pole),
            ('interference', [-0.03763371, -0.03099746, 0.11792923], [-0.15385644, 0.01265478, -1.95550977], loose),
            ('conditioning', [-0.00561806, 0.08442571, 0.51865211], [0.03774116, -0.04035305, -1.48078879], loose)):
        position, q = only_violation(node.geometry, p, r, kind)
        cases.append((node, dict(position=position, quaternion_xyzw=q), f'{kind}'))
    received = {}
    pubs = {}
    for ns in ('pole', 'loose'):
        received[ns] = probe.collect(JointState, f'/{ns}/actuators/command', qos=COMMAND_QOS)
        pubs[ns] = probe.publisher(PoseStamped, f'/{ns}/target_pose', command=True)
    with Spinner(ros_context, [pole, loose, probe]):
        for ns, node, geometry in (('pole', pole, POLE), ('loose', loose, relaxed)):
            assert wait_for(lambda: pubs[ns].get_subscription_count() == 1)
            assert wait_for(lambda: (pubs[ns].publish(target(probe, geometry.home_position)), received[ns])[1],
                            period=0.01)
        for node, kwargs, text in cases:
            ns = node.get_namespace().strip('/')
            before, rejected, k = len(received[ns]), node.rejected, len(diagnostics)
            # Sent (fresh) until the node says why in a status after the first send: a target
            # that a stall delivered late is refused as stale before its content is checked.
            assert wait_for(lambda: (pubs[ns].publish(target(probe, **kwargs)), node.rejected > rejected
                                     and said(diagnostics[k:], 'ik_node', text))[1], period=0.05), text
            assert len(received[ns]) == before, f'{text}: a rejected target was acted on'
            assert 'holding the last valid command' in node.status[1]
        count = len(received['pole'])
        assert wait_for(lambda: (pubs['pole'].publish(target(probe, home + [0.0, 0.0, 0.01])),
                                 len(received['pole']) > count)[1], period=0.01)
        assert wait_for(lambda: said(diagnostics, 'ik_node', 'tracking target_pose'))


def test_velocity_limiting_never_asks_more_than_max_speed(ros_context):
    node = IkNode(context=ros_context, namespace='/t',
                  parameter_overrides=[Parameter('limit_velocity', value=True)])
    probe = Probe(context=ros_context, namespace='/t')
    commands = probe.collect(JointState, 'actuators/command', qos=COMMAND_QOS)
    # The probe receives every target in ik_node's executor, within milliseconds of ik_node: its
    # receipt times are ik_node's time base (ik_node's dt is the time between two targets).
    targets = probe.collect(PoseStamped, 'target_pose', qos=COMMAND_QOS, stamped=True, clock='ros')
    pub = probe.publisher(PoseStamped, 'target_pose', command=True)
    state = probe.publisher(JointState, 'actuators/state')
    goal = POLE.home_position + [0.0, 0.0, 0.01]
    goal_lengths = inverse_kinematics(POLE, goal, [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 2 and state.get_subscription_count() == 1)  # ik, probe
        # No measured state yet: refused (sent until so: a late target is refused as stale first).
        assert wait_for(lambda: (pub.publish(target(probe, goal)), node.rejected >= 1
                                 and 'waits for the first' in node.status[1])[1], period=0.05)
        assert not commands
        state.publish(joint_state_msg(probe.get_clock().now().to_msg(), POLE.home_lengths))
        assert wait_for(lambda: node.measured_lengths is not None)

        def stream():
            pub.publish(target(probe, goal))
            return commands and np.allclose(commands[-1].position, goal_lengths, rtol=0, atol=1e-12)
        assert wait_for(stream, period=0.01)
    received = {header_time(m): r for r, m in targets}
    lengths = np.array([m.position for m in commands])
    t = np.array([received[header_time(m)] for m in commands])  # a command carries its target's stamp
    np.testing.assert_allclose(lengths[0], POLE.home_lengths, atol=1e-12)  # the first step is 0 s
    steps = np.max(np.abs(np.diff(lengths, axis=0)), axis=1)
    assert np.all(steps <= POLE.max_speed * node.timeout + 1e-12)  # the node's dt is capped at timeout
    # receipt times jitter (by milliseconds), so the speed is checked over the whole move: 0.01 m
    # at 0.05 m/s
    distance = np.max(np.abs(goal_lengths - POLE.home_lengths))
    assert t[-1] - t[0] >= distance / POLE.max_speed - 0.02
    assert np.median(steps) <= 1.5 * POLE.max_speed * np.median(np.diff(t)) + 1e-12


def test_an_invalid_robot_refuses_to_start(ros_context):
    with pytest.raises(RobotDescriptionError):
        IkNode(context=ros_context, parameter_overrides=[Parameter('robot', value='no_such_robot')])
