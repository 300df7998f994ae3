"""The viewer's pure core: world placement of the rings and legs, margin colours, operator control."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.limits import margins
from rrps_kinematics.scene import (
    WARN_FRACTION,
    FigureCache,
    Trail,
    leg_margin_fractions,
    margin_colours,
    robot_figure,
    torus_mesh,
    world_ring_poses,
)
from rrps_viewer._control import OperatorControl

GEOM = load_robot('pole_climber')

vectors = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)
rotvecs = st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3).map(np.array)
poses = st.builds(lambda p, r: Pose(p, rotation_vector_to_quat_xyzw(r)), vectors, rotvecs)


def _close(p1: Pose, p2: Pose) -> bool:
    return (np.allclose(p1.position, p2.position, atol=1e-9)
            and np.allclose(p1.rotation, p2.rotation, atol=1e-9))


def home() -> Pose:
    return Pose(GEOM.home_position, GEOM.home_quaternion_xyzw)


# --- poses and world placement ------------------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(poses, poses, vectors)
def test_pose_compose_matches_matrices_and_inverse(p1, p2, point):
    both = p1.compose(p2)
    assert np.allclose(both.apply(point), p1.apply(p2.apply(point)))
    assert np.allclose(both.rotation, p1.rotation @ p2.rotation)
    assert _close(p1.compose(p1.inverse()), Pose())


def test_pose_wxyz_is_viser_order_and_bad_input_is_rejected():
    q = rotation_vector_to_quat_xyzw(np.array([0.3, -0.2, 0.1]))
    assert np.allclose(Pose(np.zeros(3), q).wxyz, [q[3], q[0], q[1], q[2]])
    with pytest.raises(ValueError, match='NaN'):
        Pose([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match='zero norm'):
        Pose([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match='shape|position'):
        Pose([0.0, 0.0])


@settings(max_examples=30, deadline=None)
@given(poses, poses)
def test_world_ring_poses_keep_the_gripping_ring_and_the_relative_pose(world_T_g, a_T_b):
    wa, wb = world_ring_poses(a_T_b=a_T_b, gripping='ring_a', world_T_gripping=world_T_g)
    assert _close(wa, world_T_g)
    assert _close(wa.inverse().compose(wb), a_T_b)
    wa, wb = world_ring_poses(a_T_b=a_T_b, gripping='ring_b', world_T_gripping=world_T_g)
    assert _close(wb, world_T_g)
    assert _close(wa.inverse().compose(wb), a_T_b)


def test_world_ring_poses_rejects_an_unknown_ring():
    with pytest.raises(ValueError, match='ring_c'):
        world_ring_poses(a_T_b=Pose(), gripping='ring_c', world_T_gripping=Pose())


def test_robot_figure_legs_join_the_anchors_in_the_world():
    world_T_a = Pose([0.5, -0.2, 1.0], rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, 0.7])))
    a_T_b = Pose(GEOM.home_position + [0.01, -0.02, 0.03],
                 rotation_vector_to_quat_xyzw(np.array([0.05, 0.0, 0.1])))
    fig = robot_figure(GEOM, a_T_b=a_T_b, world_T_a=world_T_a)
    starts, ends = fig.leg_points[:, 0], fig.leg_points[:, 1]
    assert np.allclose(starts, world_T_a.apply(GEOM.ring_a_anchors))
    assert np.allclose(ends, fig.world_T_b.apply(GEOM.ring_b_anchors))
    ik = inverse_kinematics(GEOM, a_T_b.position, a_T_b.quaternion_xyzw)
    assert np.allclose(np.linalg.norm(ends - starts, axis=1), ik.lengths)
    assert np.allclose(fig.lengths, ik.lengths)
    assert fig.leg_colours.shape == (6, 3) and fig.leg_colours.dtype == np.uint8


# --- margins and colours -------------------------------------------------------------------

def test_home_pose_is_green_everywhere():
    fig = robot_figure(GEOM, a_T_b=home(), world_T_a=Pose())
    assert np.all(fig.fractions['leg'] > WARN_FRACTION)
    assert np.all(fig.leg_colours == margin_colours(np.ones(6))[0])


def test_stroke_margin_colours_the_legs_near_the_end_of_stroke():
    # Raise ring_b until the legs are just short of max_length: stroke fraction near 0.
    p = GEOM.home_position.copy()
    lengths = lambda z: inverse_kinematics(GEOM, [0.0, 0.0, z], [0, 0, 0, 1]).lengths  # noqa: E731
    lo, hi = p[2], p[2] + 0.5
    for _ in range(60):  # bisect for max(lengths) = max_length - 2 mm
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if lengths(mid).max() < GEOM.max_length - 0.002 else (lo, mid)
    fig = robot_figure(GEOM, a_T_b=Pose([0.0, 0.0, lo], [0, 0, 0, 1]), world_T_a=Pose())
    half = 0.5 * (GEOM.max_length - GEOM.min_length)
    assert np.isclose(fig.fractions['stroke'].min(), 0.002 / half, atol=1e-6)
    worst = int(np.argmin(fig.fractions['leg']))
    assert tuple(fig.leg_colours[worst]) != tuple(margin_colours(np.ones(1))[0])
    beyond = robot_figure(GEOM, a_T_b=Pose([0.0, 0.0, lo + 0.05], [0, 0, 0, 1]), world_T_a=Pose())
    assert np.all(beyond.fractions['stroke'] < 0.0)
    assert np.all(beyond.leg_colours == margin_colours(-np.ones(1))[0])


def test_force_and_joint_fractions():
    ik = inverse_kinematics(GEOM, GEOM.home_position, GEOM.home_quaternion_xyzw)
    m = margins(GEOM, ik)
    efforts = np.array([0.0, 0.5, -0.9, 1.0, 1.2, 0.25]) * GEOM.max_force
    f = leg_margin_fractions(GEOM, m, efforts)
    assert np.allclose(f['force'], [1.0, 0.5, 0.1, 0.0, -0.2, 0.75])
    assert np.allclose(f['joint'], np.minimum(m.universal / GEOM.universal_max_angle,
                                              m.spherical / GEOM.spherical_max_angle))
    assert np.allclose(f['leg'], np.minimum.reduce([f['stroke'], f['joint'], f['force']]))
    assert np.allclose(leg_margin_fractions(GEOM, m)['force'], 1.0)
    with pytest.raises(ValueError, match='efforts'):
        leg_margin_fractions(GEOM, m, np.zeros(5))


def test_margin_colours_go_from_green_through_amber_to_red_and_purple():
    c = margin_colours(np.array([1.0, WARN_FRACTION, 0.5 * WARN_FRACTION, 0.0, -0.1]))
    green, warn, amber, red, violated = (tuple(int(v) for v in row) for row in c)
    assert green == warn                      # at or above the warning level: green
    assert amber[0] > 200 and amber[1] > 120  # amber
    assert red[0] > 200 and red[1] < 60       # red at the limit
    assert violated != red
    # Redness never decreases as the margin shrinks.
    greens = margin_colours(np.linspace(WARN_FRACTION, 0.0, 20))[:, 1].astype(int)
    assert np.all(np.diff(greens) <= 0)


def test_torus_mesh_is_a_ring_about_z():
    v, f = torus_mesh(radius=0.3, tube=0.02, segments=24, tube_segments=6)
    r = np.linalg.norm(v[:, :2], axis=1)
    assert np.allclose(np.hypot(r - 0.3, v[:, 2]), 0.02, atol=1e-6)
    assert f.shape == (2 * 24 * 6, 3) and f.min() == 0 and f.max() == len(v) - 1
    with pytest.raises(ValueError):
        torus_mesh(radius=0.0, tube=0.01)


def test_trail_keeps_points_that_moved_and_caps_its_length():
    trail = Trail(min_step=0.01, max_points=3)
    assert trail.add(np.zeros(3))
    assert not trail.add(np.array([0.0, 0.0, 0.005]))
    for z in (0.02, 0.04, 0.06):
        assert trail.add(np.array([0.0, 0.0, z]))
    assert np.allclose(trail.points[:, 2], [0.02, 0.04, 0.06])
    with pytest.raises(ValueError):
        trail.add(np.array([np.nan, 0.0, 0.0]))


# --- operator control ----------------------------------------------------------------------

class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def control():
    clock = FakeClock()
    c = OperatorControl(token='s3cret-token', deadman_timeout=0.25, max_attempts=3, lockout=10.0,
                        clock=clock)
    c.clock = clock
    for client in (1, 2, 3):
        c.connect(client)
    return c


def test_every_viewer_is_read_only_until_it_enters_the_token(control):
    assert control.role(1) == 'viewer'
    assert not control.take_control(1).ok
    assert not control.set_clutch(1, True).ok
    assert not control.hold(1) and not control.set_dragging(1, True)
    assert control.controller is None and not control.enable()
    assert not control.authenticate(1, 'wrong').ok
    assert control.authenticate(1, ' s3cret-token ').ok
    assert control.role(1) == 'operator'
    assert control.take_control(1).ok and control.role(1) == 'controller'


def test_wrong_tokens_lock_a_client_out_for_a_while(control):
    for _ in range(3):
        assert not control.authenticate(2, 'guess').ok
    result = control.authenticate(2, 's3cret-token')
    assert not result.ok and 'later' in result.message
    control.clock.t += 10.5
    assert control.authenticate(2, 's3cret-token').ok
    assert not control.authenticate(99, 's3cret-token').ok  # not connected


def test_one_controller_at_a_time_and_hand_over(control):
    for c in (1, 2):
        control.authenticate(c, 's3cret-token')
    assert control.take_control(1).ok
    refused = control.take_control(2)
    assert not refused.ok and 'operator 1' in refused.message
    assert not control.hand_over(2, 1).ok           # only the holder hands over
    assert not control.hand_over(1, 3).ok           # 3 has no token
    control.set_clutch(1, True)
    control.set_dragging(1, True)
    assert control.enable()
    assert control.hand_over(1, 2).ok
    assert control.controller == 2
    assert not control.enable() and not control.clutch_engaged  # the new operator re-engages
    assert not control.set_clutch(1, True).ok
    assert control.release(2).ok and control.controller is None


def test_deadman_needs_control_clutch_and_a_fresh_hold(control):
    control.authenticate(1, 's3cret-token')
    control.take_control(1)
    assert control.hold(1) and not control.enable()          # clutch out
    assert control.set_clutch(1, True).ok
    assert control.hold(1) and control.enable()
    control.clock.t += 0.2
    assert control.enable()
    control.clock.t += 0.1                                    # 0.3 s since the last hold event
    assert not control.enable()
    control.set_dragging(1, True)
    control.clock.t += 5.0
    assert control.enable()                                   # holding the gizmo is a hold
    control.set_dragging(1, False)
    assert not control.enable()
    control.hold(1)
    control.set_clutch(1, False)
    assert not control.enable()


def test_disconnect_loses_control_and_the_robot_holds(control):
    control.authenticate(1, 's3cret-token')
    control.take_control(1)
    control.set_clutch(1, True)
    control.set_dragging(1, True)
    assert control.enable()
    version = control.version
    assert control.disconnect(1)
    assert control.version > version
    assert control.controller is None and not control.enable()
    assert not control.is_authenticated(1)
    assert not control.disconnect(2)  # a viewer leaving changes nothing


def test_token_must_be_usable():
    with pytest.raises(ValueError, match='token'):
        OperatorControl(token='abc')
    with pytest.raises(ValueError, match='deadman'):
        OperatorControl(token='abcdef', deadman_timeout=0.0)


def test_the_figure_cache_recomputes_only_when_its_inputs_change():
    g = load_robot('pole_climber')
    q = np.array([0.0, 0.0, 0.0, 1.0])
    ground = Pose(np.zeros(3), q)
    up = g.home_position + [0.0, 0.0, 0.01]
    cache = FigureCache()
    first = cache('slave', g, Pose(g.home_position, q), ground)
    assert cache('slave', g, Pose(g.home_position.copy(), q.copy()), ground) is first   # equal inputs
    moved = cache('slave', g, Pose(up, q), ground)
    assert moved is not first
    np.testing.assert_allclose(moved.lengths, inverse_kinematics(g, up, q).lengths, atol=1e-12)
    assert cache('master', g, Pose(up, q), ground) is not moved                       # one entry per key
    assert cache('slave', g, Pose(up, q), ground, np.ones(6)) is not moved            # efforts count
