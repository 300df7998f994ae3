"""The virtual fixture (rrps_teleop.fixture): the slave's limits as a feedback wrench on the master."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_multiply_xyzw, rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_jacobian, inverse_kinematics, margins
from rrps_kinematics.workspace import LIMIT_KINDS
from rrps_teleop.fixture import (
    DEFAULT_ACTIVATION,
    SOFTMIN_FRACTION,
    FixtureConfig,
    fixture_wrench,
    master_wrench,
)

POLE = load_robot('pole_climber')
FRAME = load_robot('frame_climber')
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def yawed(angle, q=IDENTITY):
    return quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, angle])), q)


def kind_margins(geometry, p, q):
    """Every margin of each kind at one pose (the components the fixture's soft minimum runs over)."""
    m = margins(geometry, inverse_kinematics(geometry, p, q))
    return {'stroke': m.stroke, 'universal': m.universal, 'spherical': m.spherical,
            'interference': m.interference, 'conditioning': np.atleast_1d(m.conditioning)}


def soft_minimum(values, d):
    tau = SOFTMIN_FRACTION * d
    return float(np.min(values) - tau * np.log(np.sum(np.exp(-(values - np.min(values)) / tau))))


def step_along(geometry, wrench, p, q, alpha):
    """The pose moved by the twist (alpha force, alpha torque / L^2): along the wrench."""
    L = geometry.characteristic_length
    return (p + alpha * wrench.force,
            quat_multiply_xyzw(rotation_vector_to_quat_xyzw(alpha * wrench.torque / L ** 2), q))


def scaled_norm(geometry, wrench):
    return float(np.hypot(np.linalg.norm(wrench.force),
                          np.linalg.norm(wrench.torque) / geometry.characteristic_length))


# Paths from inside the workspace to beyond one limit, and the limit that ends them.
PATHS = {
    'push up to the stroke': (POLE, lambda s: (POLE.home_position + [0.0, 0.0, 0.14 * s], IDENTITY),
                              'stroke'),
    'twist to the joint cones': (POLE, lambda s: (np.array([0.0, 0.0, 0.33]), yawed(0.7 + 0.32 * s)),
                                 'spherical'),
    'twist to interference': (FRAME, lambda s: (FRAME.home_position, yawed(0.55 + 0.27 * s)),
                              'interference'),
    'twist to a singularity': (FRAME, lambda s: (FRAME.home_position, yawed(-0.75 - 0.3 * s)),
                               'conditioning'),
}


@pytest.mark.parametrize('name', ['pole_climber', 'frame_climber', 'facade_climber', 'master_robot'])
def test_zero_deep_inside(name):
    g = load_robot(name)
    config = FixtureConfig(activation={'stroke': 0.1 * (g.max_length - g.min_length),
                                       'interference': g.leg_radius / 2})
    w = fixture_wrench(g, g.home_position, g.home_quaternion_xyzw, config)
    assert w.dominant is None and not any(w.pushes.values())
    np.testing.assert_array_equal(w.force, 0.0)
    np.testing.assert_array_equal(w.torque, 0.0)
    assert all(w.margins[k] > config.activation[k] for k in LIMIT_KINDS)


@pytest.mark.parametrize('path', PATHS)
def test_grows_towards_a_limit_and_points_back_inside(path):
    g, pose, limit = PATHS[path]
    config = FixtureConfig(stiffness=10.0, max_force=1e3, max_torque=1e3)  # never saturated here
    d = config.activation[limit]
    magnitudes, pushes = [], []
    for s in np.linspace(0.0, 1.0, 41):
        p, q = pose(s)
        w = fixture_wrench(g, p, q, config)
        magnitudes.append(scaled_norm(g, w))
        pushes.append(w.pushes[limit])
        if w.dominant is None:
            continue
        assert w.dominant == limit
        # A small step along the wrench increases the dominant margin (the smallest one).
        before = kind_margins(g, p, q)[limit]
        after = kind_margins(g, *step_along(g, w, p, q, 1e-6 / max(scaled_norm(g, w), 1e-9)))[limit]
        assert np.min(after) > np.min(before)
    magnitudes, pushes = np.array(magnitudes), np.array(pushes)
    assert magnitudes[0] == 0.0 and pushes[0] == 0.0              # starts inside, unpushed
    assert np.all(np.diff(pushes) >= 0.0) and np.all(np.diff(magnitudes) >= 0.0)
    assert pushes[-1] > config.stiffness                           # beyond the limit at the end
    p, q = pose(1.0)
    assert np.min(kind_margins(g, p, q)[limit]) < 0.0 < d


def test_pushing_up_is_pushed_down_symmetrically():
    """The pole climber is mirror-symmetric in y: pushing straight up is pushed straight back."""
    w = fixture_wrench(POLE, POLE.home_position + [0.0, 0.0, 0.12], IDENTITY)
    assert w.dominant == 'stroke'
    assert w.force[2] < 0.0 and abs(w.force[2]) > 100 * abs(w.force[0])
    assert abs(w.force[1]) < 1e-9 and abs(w.torque[0]) < 1e-9 and abs(w.torque[2]) < 1e-9


def test_stroke_direction_equals_the_inverse_jacobian():
    """Leg rates are J @ twist, so the stroke margin max_length - l_i has gradient -J_i: the
    fixture's direction is their soft-min weighted sum, in the metric (dp, L dtheta)."""
    p = POLE.home_position + [0.05, 0.02, 0.1]
    q = rotation_vector_to_quat_xyzw(np.array([0.02, -0.01, 0.03]))
    w = fixture_wrench(POLE, p, q)
    ik = inverse_kinematics(POLE, p, q)
    room = POLE.max_length - ik.lengths
    weights = np.exp(-(room - room.min()) / (SOFTMIN_FRACTION * DEFAULT_ACTIVATION['stroke']))
    L = POLE.characteristic_length
    gradient = -(weights @ inverse_jacobian(ik)) * np.array([1, 1, 1, 1 / L, 1 / L, 1 / L])
    direction = np.concatenate([w.force, w.torque / L])
    np.testing.assert_allclose(direction / np.linalg.norm(direction),
                               gradient / np.linalg.norm(gradient), atol=1e-7)
    assert scaled_norm(POLE, w) == pytest.approx(w.pushes['stroke'])


def test_saturates_at_the_maximum_wrench():
    config = FixtureConfig(stiffness=1e4, max_force=5.0, max_torque=0.5)
    for g, pose, limit in PATHS.values():
        w = fixture_wrench(g, *pose(1.0), config)
        assert w.pushes[limit] == config.max_force                   # each kind is capped
        f, t = np.linalg.norm(w.force), np.linalg.norm(w.torque)
        assert f <= 5.0 + 1e-12 and t <= 0.5 + 1e-12
        assert max(f / 5.0, t / 0.5) == pytest.approx(1.0)            # and the total
    gentle = fixture_wrench(POLE, *PATHS['push up to the stroke'][1](0.9), FixtureConfig())
    assert 0.0 < np.linalg.norm(gentle.force) < FixtureConfig().max_force


def test_several_kinds_add_up_and_the_strongest_dominates():
    p, q = np.array([0.0, 0.0, 0.33]), yawed(1.0)
    both = fixture_wrench(POLE, p, q)
    assert both.pushes['universal'] > 0.0 and both.pushes['spherical'] > both.pushes['universal']
    assert both.dominant == 'spherical'
    parts = [fixture_wrench(POLE, p, q, FixtureConfig(activation={k: 0.0 for k in LIMIT_KINDS if k != kind},
                                                      max_force=1e3, max_torque=1e3))
             for kind in ('universal', 'spherical')]
    total = fixture_wrench(POLE, p, q, FixtureConfig(max_force=1e3, max_torque=1e3))
    np.testing.assert_allclose(total.force, parts[0].force + parts[1].force, atol=1e-12)
    np.testing.assert_allclose(total.torque, parts[0].torque + parts[1].torque, atol=1e-12)


def test_an_activation_of_zero_turns_a_kind_off():
    p, q = PATHS['twist to interference'][1](1.0)
    off = fixture_wrench(FRAME, p, q, FixtureConfig(activation={'interference': 0.0}))
    assert off.dominant is None and off.pushes['interference'] == 0.0 and off.margins['interference'] < 0.0
    np.testing.assert_array_equal(off.force, 0.0)


@settings(max_examples=60, deadline=None)
@given(dp=st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3),
       rv=st.lists(st.floats(-0.6, 0.6), min_size=3, max_size=3),
       kind=st.sampled_from(LIMIT_KINDS), d=st.floats(0.005, 0.05))
def test_properties_of_one_kind(dp, rv, kind, d):
    """Zero exactly when the kind's margin is at least d; bounded; a step along it increases the
    kind's soft minimum (the function whose gradient gives the direction). The activation stays
    well below the margins' maxima (half the stroke, the cone angles, the 0.075 m interference
    margin of neighbouring legs at their fixed ring_a anchors), where no direction exists."""
    p = POLE.home_position + np.array(dp)
    q = rotation_vector_to_quat_xyzw(np.array(rv))
    values = kind_margins(POLE, p, q)[kind]
    assume(np.all(np.isfinite(values)))
    config = FixtureConfig(activation={k: (d if k == kind else 0.0) for k in LIMIT_KINDS})
    w = fixture_wrench(POLE, p, q, config)
    assert w.margins[kind] == pytest.approx(float(np.min(values)), abs=1e-12)
    assert (w.dominant is None) == (np.min(values) >= d)
    assert np.linalg.norm(w.force) <= config.max_force + 1e-9
    assert np.linalg.norm(w.torque) <= config.max_torque + 1e-9
    if w.dominant is not None:
        alpha = 1e-5 / scaled_norm(POLE, w)
        after = kind_margins(POLE, *step_along(POLE, w, p, q, alpha))[kind]
        assert soft_minimum(after, d) > soft_minimum(values, d)


def test_master_wrench_is_the_fixture_of_the_scaled_down_copy():
    """The master is the slave scaled by 1/s: the mapped wrench (force_scale 1) equals the fixture
    computed on the scaled copy at the scaled pose, with the length activations scaled too."""
    s = 4.0
    master = POLE.with_(ring_a_anchors=POLE.ring_a_anchors / s, ring_b_anchors=POLE.ring_b_anchors / s,
                        min_length=POLE.min_length / s, max_length=POLE.max_length / s,
                        leg_radius=POLE.leg_radius / s, home_position=None)
    metres = ('stroke', 'interference')
    big = FixtureConfig()
    small = FixtureConfig(activation={k: v / s if k in metres else v for k, v in DEFAULT_ACTIVATION.items()},
                          max_torque=big.max_torque / s)  # the same saturation, scaled down
    for g, pose, _ in (PATHS['push up to the stroke'], PATHS['twist to the joint cones']):
        p, q = pose(0.9)
        force, torque = master_wrench(fixture_wrench(POLE, p, q, big), translation_scale=s, force_scale=1.0)
        on_master = fixture_wrench(master, p / s, q, small)
        np.testing.assert_allclose(force, on_master.force, atol=1e-6)
        np.testing.assert_allclose(torque, on_master.torque, atol=1e-6)
    w = fixture_wrench(POLE, *PATHS['push up to the stroke'][1](1.0))
    force, torque = master_wrench(w, translation_scale=4.0, force_scale=0.5)
    np.testing.assert_allclose(force, 0.5 * w.force)
    np.testing.assert_allclose(torque, 0.125 * w.torque)


@pytest.mark.parametrize('kwargs,message', [
    ({'translation_scale': 0.0, 'force_scale': 1.0}, 'translation_scale must be finite and > 0'),
    ({'translation_scale': 4.0, 'force_scale': math.nan}, 'force_scale must be finite and > 0'),
])
def test_master_wrench_rejects_bad_scales(kwargs, message):
    w = fixture_wrench(POLE, POLE.home_position, IDENTITY)
    with pytest.raises(ValueError, match=message):
        master_wrench(w, **kwargs)


@pytest.mark.parametrize('position,quaternion,message', [
    ([0.0, math.nan, 0.4], IDENTITY, 'slave pose: contains NaN or infinite values'),
    ([0.0, 0.0, 0.4], [0.0, 0.0, math.inf, 1.0], 'slave pose: contains NaN or infinite values'),
    ([0.0, 0.0, 0.4], [0.0, 0.0, 0.0, 2.0], 'quaternion norm 2 is not 1'),
    ([0.0, 0.4], IDENTITY, 'position must have shape'),
])
def test_bad_poses_raise_value_error(position, quaternion, message):
    with pytest.raises(ValueError, match=message):
        fixture_wrench(POLE, position, quaternion)


def test_a_degenerate_pose_raises_value_error():
    # ring_b's anchor 1 on ring_a's anchor 1: a zero-length leg has no direction.
    p = POLE.ring_a_anchors[0] - POLE.ring_b_anchors[0]
    with pytest.raises(ValueError, match='not finite'):
        fixture_wrench(POLE, p, IDENTITY)


@pytest.mark.parametrize('kwargs,message', [
    ({'activation': {'stroke': -0.1}}, "activation\\['stroke'\\] must be a finite number >= 0"),
    ({'activation': {'stroke': math.inf}}, "activation\\['stroke'\\]"),
    ({'activation': {'elbow': 0.1}}, "unknown limit kinds \\['elbow'\\]"),
    ({'stiffness': 0.0}, 'stiffness must be finite and > 0'),
    ({'max_force': -1.0}, 'max_force must be finite and > 0'),
    ({'max_torque': math.nan}, 'max_torque must be finite and > 0'),
])
def test_bad_configs_raise_value_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        FixtureConfig(**kwargs)


def test_config_keeps_defaults_for_kinds_left_out():
    config = FixtureConfig(activation={'stroke': 0.05})
    assert config.activation['stroke'] == 0.05
    assert all(config.activation[k] == DEFAULT_ACTIVATION[k] for k in LIMIT_KINDS if k != 'stroke')
