"""Robot descriptions: the shipped YAML files, and every malformed input rejected by key."""

import copy
import math

import numpy as np
import pytest
import yaml

from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot, robot_path, shipped_robots
from rrps_kinematics import check_pose

EXPECTED_ROBOTS = {'pole_climber', 'frame_climber', 'facade_climber', 'master_robot'}


def _pole_dict():
    return yaml.safe_load(robot_path('pole_climber').read_text())


def test_the_four_architectures_are_shipped():
    assert set(shipped_robots()) == EXPECTED_ROBOTS


@pytest.mark.parametrize('name', sorted(EXPECTED_ROBOTS))
def test_shipped_robot_loads_and_is_within_limits_at_home(name):
    g = load_robot(name)
    assert g.name == name and g.description
    assert g.ring_a_anchors.shape == (6, 3) and g.ring_b_anchors.shape == (6, 3)
    assert g.min_length < g.max_length and g.leg_radius > 0
    # Home sits mid-stroke and every limit holds there.
    np.testing.assert_allclose(g.home_lengths, 0.5 * (g.min_length + g.max_length), rtol=1e-3)
    ok, reason, _ = check_pose(g, g.home_position, g.home_quaternion_xyzw)
    assert ok, reason
    # Masses and inertias are physical.
    for body in (g.ring_a_inertia, g.ring_b_inertia):
        assert body.mass > 0 and np.all(np.linalg.eigvalsh(body.inertia) > 0)
    assert g.lower_link.mass > 0 and g.upper_link.mass > 0
    np.testing.assert_allclose(np.linalg.norm(g.ring_a_joint_axes, axis=1), 1.0)


def test_frame_climber_has_the_extra_ring_dof():
    g = load_robot('frame_climber')
    assert set(g.extra_dof) == {'ring_a', 'ring_b'}
    for dof in g.extra_dof.values():
        np.testing.assert_allclose(np.linalg.norm(dof.axis), 1.0)
        assert dof.min_angle < dof.max_angle


def test_master_robot_is_a_scaled_pole_climber():
    pole, master = load_robot('pole_climber'), load_robot('master_robot')
    np.testing.assert_allclose(master.ring_a_anchors * 4, pole.ring_a_anchors, atol=1e-3)
    np.testing.assert_allclose(master.ring_b_anchors * 4, pole.ring_b_anchors, atol=1e-3)


def _set(d, dotted, value):
    keys = dotted.split('.')
    for k in keys[:-1]:
        d = d.setdefault(k, {})
    if value is _DELETE:
        del d[keys[-1]]
    else:
        d[keys[-1]] = value


_DELETE = object()
_NAN = float('nan')

MALFORMED = [
    # (dotted key to change, new value, text the message must contain)
    ('ring_a.anchors', [[0, 0, 0]] * 5, 'ring_a.anchors: expected shape (6, 3)'),
    ('ring_b.anchors', [[0, 0]] * 6, 'ring_b.anchors: expected shape (6, 3)'),
    ('ring_b.anchors', [[_NAN, 0, 0]] + [[0.1, 0.2, 0]] * 5, 'ring_b.anchors: contains NaN'),
    ('ring_a.anchors', 'six points', 'ring_a.anchors'),
    ('ring_a.anchors', _DELETE, 'ring_a.anchors: missing'),
    ('legs.min_length', 0.6, 'legs.min_length (0.6) must be < legs.max_length (0.55)'),
    ('legs.max_length', 0.3, 'legs.min_length (0.3) must be < legs.max_length (0.3)'),
    ('legs.min_length', -0.1, 'legs.min_length: must be >= 0'),
    ('legs.max_length', _NAN, 'legs.max_length: must be finite'),
    ('legs.max_speed', 0.0, 'legs.max_speed: must be > 0'),
    ('legs.max_force', -5.0, 'legs.max_force: must be > 0'),
    ('legs.max_acceleration', -0.25, 'legs.max_acceleration: must be > 0'),
    ('legs.max_acceleration', _NAN, 'legs.max_acceleration: must be finite'),
    ('legs.max_jerk', float('inf'), 'legs.max_jerk: must be finite'),
    ('legs.max_jerk', 0.0, 'legs.max_jerk: must be > 0'),
    ('legs.max_speed', _NAN, 'legs.max_speed: must be finite'),
    ('ring_a.gripper_time', {'open': -1.0, 'close': 1.0}, 'ring_a.gripper_time.open: must be > 0'),
    ('ring_b.gripper_time', {'close': _NAN}, 'ring_b.gripper_time.close: must be finite'),
    ('ring_b.gripper_time', {'shut': 1.0}, "ring_b.gripper_time: unknown keys ['shut']"),
    ('ring_a.gripper_time', 0.5, 'ring_a.gripper_time: expected a mapping'),
    ('legs.radius', -0.01, 'legs.radius: must be >= 0'),
    ('legs.radius', True, 'legs.radius: expected a number'),
    ('legs.universal_max_angle', 4.0, 'legs.universal_max_angle: must be <= pi'),
    ('legs.spherical_max_angle', 0.0, 'legs.spherical_max_angle: must be > 0'),
    ('ring_b.mass', -4.0, 'ring_b.mass: must be > 0'),
    ('ring_a.mass', 0.0, 'ring_a.mass: must be > 0'),
    ('ring_a.mass', 'heavy', 'ring_a.mass: expected a number'),
    ('legs.lower.mass', -0.5, 'legs.lower.mass: must be > 0'),
    ('legs.upper.inertia_axial', 0.0, 'legs.upper.inertia_axial: must be > 0'),
    ('legs.upper.inertia_axial', 1.0, 'legs.upper.inertia_axial: must be <= 2 * inertia_transverse'),
    ('legs.lower.com_from_joint', -0.1, 'legs.lower.com_from_joint: must be >= 0'),
    ('ring_b.inertia', [[0.27, 0.1, 0], [0, 0.27, 0], [0, 0, 0.5]], 'ring_b.inertia: inertia must be symmetric'),
    ('ring_a.inertia', [[0.27, 0, 0], [0, -0.27, 0], [0, 0, 0.5]], 'ring_a.inertia: inertia must be positive definite'),
    ('ring_a.inertia', [[0.27, 0, 0], [0, 0.27, 0], [0, 0, 0]], 'ring_a.inertia: inertia must be positive definite'),
    ('ring_b.inertia', [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.5]], 'ring_b.inertia: principal moments'),
    ('ring_b.inertia', [[0.27, 0, 0], [0, 0.27, 0]], 'ring_b.inertia: expected shape (3, 3)'),
    ('ring_b.com', [0, 0], 'ring_b.com: expected shape (3,)'),
    ('gravity', [0, 0, -9.81], "gravity: a robot description no longer gives gravity, the world does"),
    ('payload', {'mass': -1.0}, 'payload.mass: must be >= 0'),
    ('payload', {'ring': 'ring_c', 'mass': 1.0}, "payload.ring: must be 'ring_a' or 'ring_b'"),
    ('payload', {'com': [0, 0, 0]}, 'payload.mass: missing'),
    ('payload', {'mass': 1.0, 'inertia': [[1, 0, 0], [0, 1, 0], [0, 0, 3]]}, 'payload.inertia: not a physical'),
    ('payload', [1.0], 'payload: expected a mapping'),
    ('tool_wrench', {'frame': 'ring_b'}, 'tool_wrench.frame: must be one of'),
    ('tool_wrench', {'force': [1, 2]}, 'tool_wrench.force: expected shape (3,)'),
    ('tool_wrench', {'force': [1, 2, 3], 'at': 'tip'}, "tool_wrench: unknown keys ['at']"),
    ('ring_a.holding', {'clamp_force': 100.0, 'friction': 0.5}, 'ring_a.holding: give either'),
    ('ring_a.holding', {'clamp_force': 100.0, 'friction': 0.5, 'radius': 0.1, 'torque': 3.0},
     'ring_a.holding: give either'),
    ('ring_b.holding', {'axial_force': -1.0, 'shear_force': 1.0, 'torque': 1.0},
     'ring_b.holding.axial_force: must be > 0'),
    ('ring_b.holding', {'grip': 1}, "ring_b.holding: unknown keys ['grip']"),
    ('ring_b.holding', 5, 'ring_b.holding: expected a mapping'),
    ('home', {'quaternion': [0, 0, 0, 2]}, 'home.quaternion: must be a unit quaternion'),
    ('home', {'position': [0, 0]}, 'home.position: expected shape (3,)'),
    ('limits.min_conditioning', 1.5, 'limits.min_conditioning: must be < 1'),
    ('ring_a.gripper', 'glue', 'ring_a.gripper: must be one of'),
    ('extra_dof', {'ring_a': {'min_angle': 1.0, 'max_angle': -1.0}}, 'extra_dof.ring_a: min_angle must be < max_angle'),
    ('extra_dof', {'ring_c': {}}, 'extra_dof.ring_c: only ring_a and ring_b'),
    ('extra_dof', {'ring_a': {'axis': [0, 0, 0]}}, 'extra_dof.ring_a.axis: must be non-zero'),
    ('legs', [0.3, 0.5], 'legs: expected a mapping'),
    ('wheels', 4, "unknown top-level keys ['wheels']"),
]


@pytest.mark.parametrize('key,value,message', MALFORMED, ids=[f'{k}-{i}' for i, (k, _, _) in enumerate(MALFORMED)])
def test_malformed_description_names_the_key(key, value, message):
    data = _pole_dict()
    _set(data, key, value if value is _DELETE else copy.deepcopy(value))
    with pytest.raises(RobotDescriptionError) as info:
        RobotGeometry.from_dict(data, source='broken.yaml')
    assert str(info.value).startswith('broken.yaml: ')
    assert message in str(info.value)


def test_malformed_yaml_file_names_file_and_key(tmp_path):
    data = _pole_dict()
    data['ring_b']['mass'] = -1.0
    path = tmp_path / 'bad_robot.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(RobotDescriptionError, match=r'bad_robot\.yaml: ring_b\.mass: must be > 0'):
        load_robot(path)
    # YAML's own NaN spelling is caught too.
    path.write_text(path.read_text().replace('mass: -1.0', 'mass: .nan'))
    with pytest.raises(RobotDescriptionError, match=r'ring_b\.mass: must be finite'):
        RobotGeometry.from_yaml(path)


def test_unreadable_and_invalid_files(tmp_path):
    with pytest.raises(RobotDescriptionError, match='cannot read'):
        RobotGeometry.from_yaml(tmp_path / 'missing.yaml')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('ring_a: [unclosed\n')
    with pytest.raises(RobotDescriptionError, match='invalid YAML'):
        RobotGeometry.from_yaml(bad)
    bad.write_text('- just\n- a list\n')
    with pytest.raises(RobotDescriptionError, match='top level: expected a mapping'):
        RobotGeometry.from_yaml(bad)


def test_unknown_robot_name():
    with pytest.raises(RobotDescriptionError, match="unknown robot 'spider'"):
        load_robot('spider')


def test_round_trip_through_yaml_text(tmp_path):
    path = tmp_path / 'copy.yml'
    path.write_text(robot_path('facade_climber').read_text())
    a, b = load_robot('facade_climber'), load_robot(path)
    np.testing.assert_array_equal(a.ring_b_anchors, b.ring_b_anchors)
    assert a.max_length == b.max_length and a.grippers == b.grippers


def test_minimal_geometry_defaults():
    g = load_robot('pole_climber')
    custom = RobotGeometry(ring_a_anchors=g.ring_a_anchors, ring_b_anchors=g.ring_b_anchors)
    assert custom.max_length == math.inf and custom.min_conditioning == 0.0
    # Default joint axes are the home leg directions, so the cone angles are zero at home.
    home_legs = custom.home_position + custom.ring_b_anchors - custom.ring_a_anchors
    np.testing.assert_allclose(custom.ring_a_joint_axes,
                               home_legs / np.linalg.norm(home_legs, axis=1, keepdims=True))
    assert custom.characteristic_length == pytest.approx(
        np.mean(np.linalg.norm(np.vstack([g.ring_a_anchors, g.ring_b_anchors]), axis=1)))
    with pytest.raises(RobotDescriptionError, match='ring_a.anchors'):
        RobotGeometry(ring_a_anchors=np.zeros((6, 2)), ring_b_anchors=g.ring_b_anchors)
    with pytest.raises(RobotDescriptionError, match='legs.min_length'):
        g.with_(min_length=0.9)


def test_geometry_arrays_are_read_only():
    g = load_robot('pole_climber')
    with pytest.raises(ValueError):
        g.ring_a_anchors[0, 0] = 1.0


def test_motion_limits_are_the_descriptions_or_documented_defaults():
    for name in ('pole_climber', 'frame_climber', 'facade_climber', 'master_robot'):
        g = load_robot(name)
        legs = g.motion_limits.legs
        assert legs.speed == g.max_speed and legs.acceleration == g.max_acceleration and legs.jerk == g.max_jerk
    pole = load_robot('pole_climber').motion_limits
    assert (pole.grippers['ring_a'].open, pole.grippers['ring_a'].close) == (0.5, 0.8)
    # a description without acceleration, jerk or gripper times: reach full speed in 0.5 s, full
    # acceleration in 0.2 s, a gripper switch in 2 s
    data = _pole_dict()
    for key in ('legs.max_acceleration', 'legs.max_jerk', 'ring_a.gripper_time', 'ring_b.gripper_time'):
        _set(data, key, _DELETE)
    limits = RobotGeometry.from_dict(data).motion_limits
    assert limits.legs.acceleration == pytest.approx(0.05 / 0.5) and limits.legs.jerk == pytest.approx(0.1 / 0.2)
    assert limits.grippers['ring_b'].switch(close=True) == limits.grippers['ring_a'].switch(close=False) == 2.0
    # without the speed nothing can be timed: the error names the key
    _set(data, 'legs.max_speed', _DELETE)
    with pytest.raises(RobotDescriptionError, match='legs.max_speed: not given'):
        RobotGeometry.from_dict(data).motion_limits


def test_per_geometry_computes_once_per_geometry_object():
    """A derived constant is computed once for each geometry object, never shared between two
    geometries that merely look alike (a robot reloaded, a variant built with dataclasses.replace)."""
    from rrps_description.geometry import per_geometry

    calls = []

    @per_geometry
    def anchor_sum(geometry):
        calls.append(geometry)
        return float(np.sum(geometry.ring_a_anchors))

    g, h = load_robot('pole_climber'), load_robot('pole_climber')
    assert anchor_sum(g) == anchor_sum(g) == anchor_sum(h)
    assert [c is g for c in calls] == [True, False]
    moved = RobotGeometry(ring_a_anchors=2.0 * g.ring_a_anchors, ring_b_anchors=g.ring_b_anchors)
    assert anchor_sum(moved) == pytest.approx(2.0 * anchor_sum(g))
    assert len(calls) == 3
