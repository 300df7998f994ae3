"""/tf as REP-105 wants it, read as RViz2 or tf2 would: the tree ``odom -> base_link ->`` every
link of the robot's URDF (its own XML, parsed here), one parent each and one root; and in a fleet
of three robots in one domain, each robot's frames under its ``frame_prefix``, three disjoint
trees where the robots' positions are their own."""

from __future__ import annotations

import importlib.util
import os
import secrets
import xml.etree.ElementTree as ET

import pytest

from rrps_testing.ci import require
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = pytest.mark.ros

NS = f'/rrps_{os.getpid()}_{secrets.token_hex(3)}'


def _tree(*messages) -> dict[str, list[str]]:
    """{child: [its parents]} of every transform of /tf and /tf_static messages."""
    parents: dict[str, list[str]] = {}
    for msg in messages:
        for t in msg.transforms:
            if t.header.frame_id not in parents.get(t.child_frame_id, []):
                parents.setdefault(t.child_frame_id, []).append(t.header.frame_id)
    return parents


def _root_of(parents: dict[str, list[str]], frame: str) -> list[str]:
    """The chain from ``frame`` up to its root (assumes one parent each)."""
    chain = [frame]
    while chain[-1] in parents:
        chain.append(parents[chain[-1]][0])
        assert len(chain) < 200, chain
    return chain


def _markers_node(ctx, namespace, prefix=''):
    from rclpy.parameter import Parameter

    from rrps_recording.nodes.markers_node import MarkersNode
    return MarkersNode(context=ctx, namespace=namespace, parameter_overrides=[
        Parameter('tf_rate', value=50.0), Parameter('frame_prefix', value=prefix)])


def _feed(probe, z: float) -> None:
    """The robot at home with ring_a gripping at height ``z`` in odom."""
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState

    from rrps_description.geometry import load_robot
    from rrps_runtime.messages import joint_state_msg, pose_to_msg
    g = load_robot('pole_climber')
    stamp = probe.get_clock().now().to_msg()
    probe.publisher(PoseStamped, 'pose').publish(
        pose_to_msg(g.home_position, g.home_quaternion_xyzw, frame_id='ring_a', stamp=stamp))
    probe.publisher(JointState, 'grippers/state').publish(
        joint_state_msg(stamp, [1.0, 1.0], names=['ring_a', 'ring_b']))
    probe.publisher(PoseStamped, 'odometry/ring_a').publish(pose_to_msg([0.0, 0.0, z], [0, 0, 0, 1], frame_id='odom',
                                                                        stamp=stamp))


def _subscribe_tf(probe):
    """/tf and /tf_static as tf2_ros' TransformListener reads them (/tf_static: depth 100, so that
    every robot's latched message is kept)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from tf2_msgs.msg import TFMessage
    static: list = []
    probe.create_subscription(TFMessage, '/tf_static', static.append, QoSProfile(
        depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    return probe.collect(TFMessage, '/tf'), static


def test_tf_is_the_rep105_tree_from_odom_through_base_link_to_every_urdf_link(ros_context):
    require(importlib.util.find_spec('tf2_msgs') is not None, 'tf2_msgs is not installed')
    from rrps_description.geometry import load_robot
    from rrps_kinematics.urdf_joints import robot_urdf

    urdf = ET.fromstring(robot_urdf(load_robot('pole_climber')))
    links = {link.get('name') for link in urdf.iter('link')}
    node = _markers_node(ros_context, NS)
    probe = Probe(context=ros_context, namespace=NS)
    tf, static = _subscribe_tf(probe)
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: probe.count_subscribers(f'{NS}/odometry/ring_a') > 0 and static)
        _feed(probe, 1.5)
        assert wait_for(lambda: tf and _tree(tf[-1]).get('base_link') == ['odom'])
        parents = _tree(tf[-1], static[-1])
    assert all(len(p) == 1 for p in parents.values()), {c: p for c, p in parents.items() if len(p) > 1}
    frames = set(parents) | {p[0] for p in parents.values()}
    assert frames == links | {'odom'}                      # the URDF's links, and odom above them
    assert {f for f in frames if f not in parents} == {'odom'}  # one root
    for link in links:
        chain = _root_of(parents, link)
        assert chain[-2:] == ['base_link', 'odom'], chain  # every link hangs from base_link
    assert _root_of(parents, 'ring_a')[:2] == ['ring_a', 'base_link']
    odom_base = next(t for t in tf[-1].transforms if t.child_frame_id == 'base_link').transform
    assert odom_base.translation.z == pytest.approx(1.5)


def test_a_fleet_of_three_robots_keeps_each_robots_frames_under_its_prefix(ros_context):
    require(importlib.util.find_spec('tf2_msgs') is not None, 'tf2_msgs is not installed')
    robots = {j: (f'{NS}/robot_{j}', f'robot_{j}/') for j in (1, 2, 3)}
    nodes = [_markers_node(ros_context, ns, prefix) for ns, prefix in robots.values()]
    probes = {j: Probe(context=ros_context, name=f'probe_{j}', namespace=ns) for j, (ns, _) in robots.items()}
    tf, static = _subscribe_tf(probes[1])
    with Spinner(ros_context, [*nodes, *probes.values()]):
        assert wait_for(lambda: all(p.count_subscribers(f'{robots[j][0]}/odometry/ring_a') > 0
                                    for j, p in probes.items()))
        assert wait_for(lambda: len(static) >= 3), len(static)
        for j, probe in probes.items():
            _feed(probe, float(j))
        assert wait_for(lambda: all(_tree(*tf[-30:]).get(f'robot_{j}/base_link') == [f'robot_{j}/odom']
                                    for j in robots))
        parents = _tree(*tf[-30:], *static)
    assert all(len(p) == 1 for p in parents.values())      # no frame of two robots' trees
    single = {f for f in _tree(*tf[-30:], *static)}
    for j, (_, prefix) in robots.items():
        mine = {f for f in single if f.startswith(prefix)}
        assert {f'{prefix}base_link', f'{prefix}ring_a', f'{prefix}ring_b', f'{prefix}leg_1_tip'} <= mine
        for frame in mine:
            chain = _root_of(parents, frame)
            assert chain[-1] == f'{prefix}odom' and all(f.startswith(prefix) for f in chain), chain
        odom_base = [t.transform.translation.z for msg in tf[-30:] for t in msg.transforms
                     if t.child_frame_id == f'{prefix}base_link']
        assert odom_base and all(z == pytest.approx(float(j)) for z in odom_base)
    assert all(any(f.startswith(prefix) for _, prefix in robots.values()) for f in single)
