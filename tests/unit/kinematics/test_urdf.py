"""The URDF against an independent parser and forward kinematics (yourdfpy): for every shipped
robot it parses, its joints, limits and inertias are the robot description's, and the joint
states of a pose put every leg's tip on its ring_b anchor and ring_b where our FK says; our /tf
tree is the one a URDF parser computes; urdfdom (robot_state_publisher's parser) reads it.
``rrps-kinematics urdf`` writes it."""

from __future__ import annotations

import io
import math
import os
import re
import shutil
import subprocess
from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pytest
import yaml
import yourdfpy

from rrps_description.geometry import RobotGeometry, load_robot, robot_path, shipped_robots
from rrps_description.pose import Pose
from rrps_description.rotations import (
    matrix_to_rpy,
    rotation_angle_between,
    rotation_vector_to_quat_xyzw,
    rpy_to_matrix,
)
from rrps_description.urdf import UNBOUNDED, leg_chain
from rrps_kinematics import forward_kinematics, inverse_kinematics
from rrps_kinematics.cli import run
from rrps_kinematics.limits import margins
from rrps_kinematics.urdf_joints import joint_values, robot_model, robot_urdf
from rrps_recording.markers import robot_transforms
from rrps_testing.transform_tree import pose_in

ROBOTS = shipped_robots()


def _parse(text: str) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(io.StringIO(text), build_collision_scene_graph=False, load_meshes=False)


def _random_pose(g: RobotGeometry, rng: np.random.Generator) -> Pose:
    """A random pose around home within every limit (rejection sampling)."""
    stroke = g.max_length - g.min_length
    for _ in range(1000):
        p = g.home_position + rng.normal(scale=0.15 * stroke, size=3)
        turn = rotation_vector_to_quat_xyzw(rng.normal(scale=0.15, size=3))
        pose = Pose(p, g.home_quaternion_xyzw) @ Pose((0.0, 0.0, 0.0), turn)
        if margins(g, inverse_kinematics(g, pose.position, pose.quaternion_xyzw)).ok:
            return pose
    raise AssertionError('no pose within the limits')


@pytest.mark.parametrize('name', ROBOTS)
def test_the_urdf_parses_with_the_descriptions_joints_limits_and_inertias(name):
    g = load_robot(name)
    urdf = _parse(robot_urdf(g))
    assert urdf.validate()
    assert urdf.base_link == 'base_link'  # REP-105, with ring_a fixed on it at identity
    np.testing.assert_array_equal(urdf.get_transform('ring_a', 'base_link'), np.eye(4))
    joints = urdf.robot.joints
    dof = sorted(g.extra_dof)
    # per leg: 2 universal + 1 prismatic + 3 spherical; one ring DOF joint per ring that has it
    assert len(urdf.actuated_joint_names) == 36 + len(dof)
    assert list(urdf.actuated_joint_names) == list(robot_model(g).moving_joints)
    kinds = [j.type for j in joints]
    assert kinds.count('prismatic') == 6 and kinds.count('continuous') == 6
    assert kinds.count('revolute') == 24 + len(dof)
    fixed = {j.child: j.parent for j in joints if j.type == 'fixed'}
    assert fixed['ring_b'] == 'leg_1_tip' and fixed['ring_a_body'] == 'ring_a' and fixed['ring_a'] == 'base_link'
    assert ('tool' in fixed) == (g.tool is not None)
    for leg in range(1, 7):
        chain = leg_chain(leg)
        stroke = urdf.joint_map[chain.prismatic].limit
        assert (stroke.lower, stroke.upper) == (g.min_length, g.max_length)
        assert (stroke.effort, stroke.velocity) == (g.max_force, g.max_speed)
        for joint, cone in [(n, g.universal_max_angle) for n in chain.universal] + \
                           [(n, g.spherical_max_angle) for n in chain.spherical[1:]]:
            limit = urdf.joint_map[joint].limit
            assert (limit.lower, limit.upper) == (-cone, cone), joint
        assert urdf.joint_map[chain.spherical[0]].limit is None  # the twist: continuous
    for ring in dof:
        limit = urdf.joint_map[f'{ring}_rotation'].limit
        assert (limit.lower, limit.upper) == (g.extra_dof[ring].min_angle, g.extra_dof[ring].max_angle)
    inertial = {name: link.inertial for name, link in urdf.link_map.items() if link.inertial is not None}
    assert urdf.link_map['base_link'].inertial is None  # KDL takes no inertia on the root
    for link, value in inertial.items():
        assert value.mass > 0.0 and np.all(np.linalg.eigvalsh(value.inertia) > 0.0), link
    assert inertial['ring_a_body'].mass == g.ring_a_inertia.mass
    np.testing.assert_array_equal(inertial['ring_b'].inertia, g.ring_b_inertia.inertia)
    np.testing.assert_array_equal(inertial['ring_b'].origin[:3, 3], g.ring_b_inertia.com)
    assert inertial['leg_3_lower'].origin[2, 3] == g.lower_link.com_from_joint
    assert inertial['leg_3_upper'].origin[2, 3] == -g.upper_link.com_from_joint
    assert np.diag(inertial['leg_3_upper'].inertia).tolist() == [
        g.upper_link.inertia_transverse, g.upper_link.inertia_transverse, g.upper_link.inertia_axial]
    assert len(inertial) == 2 + 12 + (g.tool is not None)


@pytest.mark.parametrize('name', ROBOTS)
def test_joint_states_put_the_tips_on_ring_b_and_ring_b_where_fk_says(name):
    """yourdfpy's FK of the joint states of our FK's pose (from the legs' lengths)."""
    g = load_robot(name)
    urdf = _parse(robot_urdf(g))
    rng = np.random.default_rng(sum(map(ord, name)))
    for _ in range(25):
        pose = _random_pose(g, rng)
        lengths = inverse_kinematics(g, pose.position, pose.quaternion_xyzw).lengths
        fk = forward_kinematics(g, lengths)
        assert fk.converged
        a_T_b = Pose(fk.position, fk.quaternion_xyzw)
        world_T_a = Pose(rng.normal(size=3), rotation_vector_to_quat_xyzw(rng.normal(size=3)))
        world_T_b = world_T_a @ a_T_b
        rings = {f'{ring}_rotation': float(rng.uniform(-1.0, 1.0)) for ring in g.extra_dof}
        urdf.update_cfg(joint_values(g, a_T_b, rings))
        for i in range(6):
            tip = world_T_a.apply(urdf.get_transform(leg_chain(i + 1).tip, 'ring_a')[:3, 3])
            assert np.linalg.norm(tip - world_T_b.apply(g.ring_b_anchors[i])) < 1e-9
        T = world_T_a.matrix @ urdf.get_transform('ring_b', 'ring_a')
        assert np.linalg.norm(T[:3, 3] - world_T_b.position) < 1e-9
        assert rotation_angle_between(T[:3, :3], world_T_b.rotation) < 1e-9
        for ring, angle in rings.items():  # the gripper turned about the DOF axis
            gripper = urdf.get_transform(f'{ring.removesuffix("_rotation")}_gripper',
                                         ring.removesuffix('_rotation'))
            assert rotation_angle_between(gripper[:3, :3], np.eye(3)) == pytest.approx(abs(angle), abs=1e-12)


@pytest.mark.parametrize('name', ROBOTS)
def test_our_tf_tree_is_the_one_a_urdf_parser_computes(name):
    """robot_transforms (markers_node's /tf, the recorder's) = the URDF's link poses."""
    g = load_robot(name)
    urdf = _parse(robot_urdf(g))
    a_T_b = _random_pose(g, np.random.default_rng(3))
    world_T_a = Pose([0.3, -0.2, 1.1], rotation_vector_to_quat_xyzw([0.1, 0.2, 0.3]))
    rings = {f'{ring}_rotation': 0.4 for ring in g.extra_dof}
    tree = robot_transforms(g, a_T_b, world_T_a, rings)
    urdf.update_cfg(joint_values(g, a_T_b, rings))
    assert {child for _, child, _ in tree} == set(urdf.link_map)  # base_link: from odom
    for link in urdf.link_map:
        ours = pose_in(tree, link, 'odom')
        theirs = world_T_a.matrix @ urdf.get_transform(link, 'base_link')
        assert np.linalg.norm(ours.position - theirs[:3, 3]) < 1e-12, link
        assert rotation_angle_between(ours.rotation, theirs[:3, :3]) < 1e-9, link


def test_the_cached_joint_frames_cannot_be_changed_by_a_caller():
    """The yoke and socket frames are computed once per geometry: a caller writing into them
    would change every later pose's joint values, so they are read-only."""
    from rrps_description.urdf import socket_frames
    from rrps_kinematics.inverse import universal_joint_frames
    g = load_robot('pole_climber')
    for frames in (universal_joint_frames(g), socket_frames(g)):
        assert not frames.flags.writeable
        with pytest.raises(ValueError):
            frames[0, 0, 0] = 1.0


@pytest.mark.parametrize('name', ROBOTS)
def test_the_spherical_joints_stay_far_from_gimbal_lock(name):
    """Home: the tilt angles are 0; anywhere, cos(cone angle) = cos(x) cos(y), so |x| <= the cone
    angle < pi/2 and the box limits contain the cone; the universal joint likewise."""
    g = load_robot(name)
    home = joint_values(g, Pose(g.home_position, g.home_quaternion_xyzw))
    rng = np.random.default_rng(7)
    for pose in [Pose(g.home_position, g.home_quaternion_xyzw)] + [_random_pose(g, rng) for _ in range(25)]:
        values = joint_values(g, pose)
        ik = inverse_kinematics(g, pose.position, pose.quaternion_xyzw)
        for i in range(6):
            chain = leg_chain(i + 1)
            x, y = (values[n] for n in chain.spherical[1:])
            assert math.cos(x) * math.cos(y) == pytest.approx(math.cos(ik.spherical_cone_angles[i]), abs=1e-12)
            assert abs(x) <= ik.spherical_cone_angles[i] + 1e-12 < math.pi / 2
            u1, u2 = (values[n] for n in chain.universal)
            assert math.cos(u1) * math.cos(u2) == pytest.approx(math.cos(ik.universal_cone_angles[i]), abs=1e-12)
            assert values[chain.prismatic] == ik.lengths[i]
    assert max(abs(home[n]) for i in range(1, 7) for n in leg_chain(i).spherical[1:]) < 1e-12


def _check_urdf(path: Path) -> subprocess.CompletedProcess:
    """urdfdom's check_urdf: the C++ parser under robot_state_publisher (cmeel-urdfdom)."""
    prefix = Path(str(distribution('cmeel-urdfdom').locate_file('cmeel.prefix')))
    return subprocess.run([str(prefix / 'bin' / 'check_urdf'), str(path)], capture_output=True, text=True,
                          env={**os.environ, 'LD_LIBRARY_PATH': str(prefix / 'lib')}, timeout=60)


@pytest.mark.parametrize('name', ROBOTS)
def test_urdfdom_robot_state_publishers_parser_reads_the_tree(name, tmp_path):
    g = load_robot(name)
    path = tmp_path / f'{name}.urdf'
    path.write_text(robot_urdf(g))
    result = _check_urdf(path)
    assert result.returncode == 0, result.stderr
    assert 'root Link: base_link has' in result.stdout
    links = {line.split(':', 1)[1].strip() for line in result.stdout.splitlines()
             if line.strip().startswith('child(')}
    assert links == set(_parse(robot_urdf(g)).link_map) - {'base_link'}
    # and it refuses what it must: a limit without an effort
    path.write_text(re.sub(r' effort="[^"]*"', '', robot_urdf(g), count=1))
    assert _check_urdf(path).returncode != 0


def test_a_users_robot_file_with_its_own_joint_axes_and_no_limits(tmp_path):
    """Any robot file: joint axes given (not along the home legs), the stroke unbounded."""
    data = yaml.safe_load(robot_path('facade_climber').read_text())
    data['ring_b']['joint_axes'] = [[0.1, 0.2 * k - 0.5, -1.0] for k in range(6)]
    for key in ('max_length', 'max_speed', 'max_force'):
        data['legs'].pop(key)
    data.pop('bus', None)          # CANopen drives need a finite stroke (tested in test_bus)
    path = tmp_path / 'mine.yaml'
    path.write_text(yaml.safe_dump(data))
    g = load_robot(str(path))
    text = robot_urdf(g)
    urdf = _parse(text)
    assert urdf.joint_map['leg_2'].limit.upper == UNBOUNDED and 'max_length, max_force, max_speed' in text
    (tmp_path / 'mine.urdf').write_text(text)
    assert _check_urdf(tmp_path / 'mine.urdf').returncode == 0
    a_T_b = Pose(g.home_position + [0.01, -0.02, 0.03], rotation_vector_to_quat_xyzw([0.05, 0.0, 0.1]))
    urdf.update_cfg(joint_values(g, a_T_b))
    for i in range(6):
        assert np.linalg.norm(urdf.get_transform(f'leg_{i + 1}_tip', 'ring_a')[:3, 3]
                              - a_T_b.apply(g.ring_b_anchors[i])) < 1e-9
    assert np.linalg.norm(urdf.get_transform('ring_b', 'ring_a') - a_T_b.matrix) < 1e-9


def test_rpy_round_trips_near_gimbal_lock_too():
    rng = np.random.default_rng(1)
    angles = [rng.uniform(-math.pi, math.pi, 3) for _ in range(200)]
    angles += [(a, s * math.pi / 2 + d, b) for a, b in rng.uniform(-3, 3, (20, 2))
               for s in (-1, 1) for d in (0.0, 1e-9, -1e-7)]
    for rpy in angles:
        R = rpy_to_matrix(rpy)
        assert np.abs(rpy_to_matrix(matrix_to_rpy(R)) - R).max() < 1e-14
    # URDF's convention: fixed axes x, then y, then z
    assert np.allclose(rpy_to_matrix((0.0, 0.0, 0.5)) @ [1, 0, 0], [math.cos(0.5), math.sin(0.5), 0])
    assert np.allclose(rpy_to_matrix((0.3, 0.2, 0.1)),
                       Pose((0, 0, 0), rotation_vector_to_quat_xyzw([0, 0, 0.1])).rotation
                       @ Pose((0, 0, 0), rotation_vector_to_quat_xyzw([0, 0.2, 0])).rotation
                       @ Pose((0, 0, 0), rotation_vector_to_quat_xyzw([0.3, 0, 0])).rotation)


def test_rrps_kinematics_urdf_writes_a_valid_file(tmp_path, capsys):
    path = tmp_path / 'frame.urdf'
    assert run(['urdf', '--robot', 'frame_climber', '--output', str(path)]) == 0
    assert capsys.readouterr().out == f'wrote {path}\n'
    urdf = yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_meshes=False)
    assert urdf.validate() and urdf.robot.name == 'frame_climber'
    assert 'cannot close loops' in path.read_text()
    assert run(['urdf']) == 0  # stdout: the pole climber
    assert _parse(capsys.readouterr().out).robot.name == 'pole_climber'


def test_rrps_kinematics_urdf_bad_robot_is_one_line_and_exit_2(tmp_path, capsys):
    assert run(['urdf', '--robot', 'no_such_robot']) == 2
    out, err = capsys.readouterr()
    assert out == '' and err.count('\n') == 1 and "unknown robot 'no_such_robot'" in err
    assert run(['urdf', '--output', str(tmp_path / 'missing' / 'x.urdf')]) == 2
    assert 'cannot write' in capsys.readouterr().err
    exe = shutil.which('rrps-kinematics')
    if exe is not None:  # the installed console script
        result = subprocess.run([exe, 'urdf', '--robot', str(tmp_path / 'nope.yaml')], capture_output=True,
                                text=True, timeout=60)
        assert result.returncode == 2 and result.stdout == '' and result.stderr.count('\n') == 1
