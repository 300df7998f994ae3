"""Signed margins of rrps_kinematics.limits: signs, leg naming, batches and segment distances."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import RobotGeometry, load_robot
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_kinematics import PAIRS, check_pose, inverse_kinematics, margins
from rrps_kinematics.backend import use_numba
from rrps_kinematics.limits import segment_distances
from rrps_testing.ci import require

POLE = load_robot('pole_climber')


def test_single_pose_shapes_at_home():
    g = POLE
    ok, reason, m = check_pose(g, g.home_position, g.home_quaternion_xyzw)
    assert ok is True and m.within_limits is True and reason == 'within limits' == m.reason
    assert m.violations() == []
    assert m.stroke.shape == m.universal.shape == m.spherical.shape == (6,)
    assert m.interference.shape == (15,) and np.ndim(m.conditioning) == 0
    assert 0.0 < m.inverse_condition <= 1.0
    assert set(m.minimum) == {'stroke', 'universal', 'spherical', 'interference', 'conditioning'}


def test_pairs_table():
    assert PAIRS.shape == (15, 2)
    assert {tuple(p) for p in PAIRS} == {(i, j) for i in range(6) for j in range(i + 1, 6)}


def test_stroke_violations_name_the_legs():
    g = POLE
    up = g.home_position + [0.0, 0.0, 0.3]
    ok, reason, m = check_pose(g, up, g.home_quaternion_xyzw)
    assert not ok
    assert np.all(m.stroke < 0)
    np.testing.assert_allclose(m.stroke, g.max_length - m.lengths)
    for i in range(1, 7):
        assert f'leg_{i} length' in reason and '> max_length' in reason
    down = g.home_position - [0.0, 0.0, 0.2]
    ok, reason, m = check_pose(g, down, g.home_quaternion_xyzw)
    assert not ok and '< min_length' in reason
    np.testing.assert_allclose(m.stroke, m.lengths - g.min_length)


def test_only_the_legs_out_of_stroke_are_named():
    g = POLE
    # A 0.25 m sideways shift stretches legs 3 and 6 beyond max_length, the others stay inside.
    ok, reason, m = check_pose(g, g.home_position + [0.25, 0.0, 0.0], g.home_quaternion_xyzw)
    bad = np.flatnonzero(m.stroke < 0)
    assert not ok and 0 < bad.size < 6
    for i in range(6):
        assert (f'stroke: leg_{i + 1} ' in reason) == (i in bad)


def test_interference_of_crossing_legs():
    g = POLE
    B = g.ring_b_anchors.copy()
    B[[0, 1]] = B[[1, 0]]  # legs 1 and 2 now cross each other
    crossed = RobotGeometry(ring_a_anchors=g.ring_a_anchors, ring_b_anchors=B, leg_radius=0.02,
                            min_length=g.min_length, max_length=g.max_length)
    ok, reason, m = check_pose(crossed, crossed.home_position, crossed.home_quaternion_xyzw)
    k = next(p for p, (i, j) in enumerate(PAIRS) if (i, j) == (0, 1))
    assert m.interference[k] < 0 and m.segment_distances[k] < 1e-9
    assert not ok and 'interference: leg_1 and leg_2' in reason
    assert np.sum(m.interference < 0) == 1


def test_conditioning_of_a_singular_design():
    # All spherical joints at ring_b's origin: ring_b can spin about it, J loses rank 3.
    g = RobotGeometry(ring_a_anchors=POLE.ring_a_anchors, ring_b_anchors=np.zeros((6, 3)),
                      min_conditioning=0.01)
    ok, reason, m = check_pose(g, g.home_position, g.home_quaternion_xyzw)
    assert m.inverse_condition < 1e-12
    assert not ok and reason.startswith('conditioning: inverse condition number')


def test_conditioning_is_unit_consistent():
    """Scaling the whole robot (and the pose) leaves the inverse condition number unchanged."""
    g = POLE
    scaled = RobotGeometry(ring_a_anchors=3 * g.ring_a_anchors, ring_b_anchors=3 * g.ring_b_anchors)
    q = rotation_vector_to_quat_xyzw([0.1, -0.05, 0.2])
    p = g.home_position + [0.02, 0.01, -0.03]
    m1 = margins(g, inverse_kinematics(g, p, q))
    m2 = margins(scaled, inverse_kinematics(scaled, 3 * p, q))
    assert m1.inverse_condition == pytest.approx(m2.inverse_condition, rel=1e-9)


def test_joint_angle_margins_against_arccos():
    g = POLE
    rng = np.random.default_rng(3)
    n = 200
    P = g.home_position + rng.uniform(-0.1, 0.1, (n, 3))
    Q = rotation_vector_to_quat_xyzw(rng.uniform(-0.6, 0.6, (n, 3)))
    ik = inverse_kinematics(g, P, Q)
    m = margins(g, ik)
    u = ik.unit_vectors
    ua = np.arccos(np.clip(np.einsum('nij,ij->ni', u, g.ring_a_joint_axes), -1, 1))
    towards_a_in_b = -np.einsum('nkj,nik->nij', ik.rotation, u)
    sa = np.arccos(np.clip(np.einsum('nij,ij->ni', towards_a_in_b, g.ring_b_joint_axes), -1, 1))
    np.testing.assert_allclose(m.universal, g.universal_max_angle - ua, atol=1e-7)
    np.testing.assert_allclose(m.spherical, g.spherical_max_angle - sa, atol=1e-7)
    # Both kinds of violations occur in this sample and are named.
    assert np.any(m.universal < 0) and np.any(m.spherical < 0) and np.any(m.ok)
    text = '\n'.join(m.violations())
    assert 'universal joint: leg_' in text and 'spherical joint: leg_' in text


def test_batch_equals_single_and_ok_is_all_margins():
    g = load_robot('frame_climber')
    rng = np.random.default_rng(7)
    n = 64
    P = g.home_position + rng.uniform(-0.25, 0.25, (n, 3))
    Q = rotation_vector_to_quat_xyzw(rng.uniform(-0.7, 0.7, (n, 3)))
    mb = margins(g, inverse_kinematics(g, P, Q))
    assert mb.ok.shape == (n,) and mb.stroke.shape == (n, 6) and mb.interference.shape == (n, 15)
    assert 0 < np.sum(mb.ok) < n
    lines = mb.violations()
    for k in range(n):
        ok, reason, ms = check_pose(g, P[k], Q[k])
        assert ok == mb.ok[k]
        for name in ('stroke', 'universal', 'spherical', 'interference', 'conditioning'):
            np.testing.assert_allclose(getattr(ms, name), getattr(mb, name)[k], atol=1e-12)
        expected = all(np.all(getattr(ms, f) >= 0) for f in
                       ('stroke', 'universal', 'spherical', 'interference', 'conditioning'))
        assert ok == expected
        assert (reason == 'within limits') == ok
        assert ms.violations() == [line.split(': ', 1)[1] for line in lines
                                   if line.startswith(f'pose {k}: ')]


def test_check_pose_rejects_batches_and_bad_input():
    g = POLE
    with pytest.raises(ValueError, match='single pose'):
        check_pose(g, np.zeros((2, 3)), np.tile([0, 0, 0, 1.0], (2, 1)))
    with pytest.raises(ValueError, match='NaN'):
        check_pose(g, [np.nan, 0, 0.4], [0, 0, 0, 1.0])


def _brute_force_distance(p0, p1, q0, q1, n=401):
    s = np.linspace(0, 1, n)
    P = p0 + s[:, None] * (p1 - p0)
    Q = q0 + s[:, None] * (q1 - q0)
    return np.min(np.linalg.norm(P[:, None] - Q[None], axis=-1))


coords = st.floats(-1.0, 1.0, allow_nan=False)
point = st.tuples(coords, coords, coords).map(np.array)


@settings(max_examples=60, deadline=None)
@given(point, point, point, point)
def test_segment_distance_matches_sampling(p0, p1, q0, q1):
    d = segment_distances(p0, p1, q0, q1)
    brute = _brute_force_distance(p0, p1, q0, q1)
    # Sampling finds an upper bound within one sample step of the true minimum.
    step = (np.linalg.norm(p1 - p0) + np.linalg.norm(q1 - q0)) / 400
    assert d <= brute + 1e-12
    assert d >= brute - step - 1e-12


def test_segment_distance_special_cases():
    o = np.zeros(3)
    x = np.array([1.0, 0, 0])
    y = np.array([0, 1.0, 0])
    z = np.array([0, 0, 1.0])
    assert segment_distances(o, x, y, x + y) == pytest.approx(1.0)          # parallel
    assert segment_distances(o, x, 2 * x, 3 * x) == pytest.approx(1.0)      # collinear, apart
    assert segment_distances(o, o, z, z) == pytest.approx(1.0)              # two points
    assert segment_distances(o, x, 0.5 * x + z, 0.5 * x + z) == pytest.approx(1.0)  # one point
    assert segment_distances(-x, x, -y + z, y + z) == pytest.approx(1.0)    # crossing, skew


@pytest.mark.parametrize('tilt', [6e-8, 1e-7, 1e-6])
def test_nearly_antiparallel_segments_that_share_an_endpoint_touch(tilt):
    """Found by hypothesis: a nearly parallel pair is within the parallel tolerance, and the
    closest points must still come from the shared endpoint, not from s = 0."""
    p0, p1 = np.zeros(3), np.array([0.0, 0.0, 1.0])
    q0, q1 = p1.copy(), np.array([0.0, tilt, 0.0])
    from rrps_testing.reference_limits import segment_distance
    assert segment_distances(p0, p1, q0, q1) == 0.0
    assert segment_distances(p0, p1, q0, q1, backend='numpy') == 0.0
    require(use_numba('auto'), 'numba is not in use')
    from rrps_kinematics import compiled_limits as compiled
    assert compiled.segment_distance(p0, p1, q0, q1) == 0.0
    assert compiled.segment_distance(p0, p1, q0 + [1e-3, 0, 0], q1) == pytest.approx(
        segment_distances(p0, p1, q0 + [1e-3, 0, 0], q1), abs=1e-15)
    assert compiled.segment_distance(p0, p1, q0 + [1e-3, 0, 0], q1) == pytest.approx(
        segment_distance(p0, p1, q0 + [1e-3, 0, 0], q1), abs=1e-15)


@settings(max_examples=50, deadline=None)
@given(st.tuples(*[st.floats(-0.6, 0.6, allow_nan=False)] * 3),
       st.tuples(*[st.floats(-0.8, 0.8, allow_nan=False)] * 3))
def test_margin_signs_match_direct_checks(dp, rv):
    """Each margin is >= 0 exactly when the limit, checked directly from the anchors, holds."""
    g = POLE
    p = g.home_position + np.array(dp) * g.characteristic_length
    q = rotation_vector_to_quat_xyzw(np.array(rv))
    ok, _, m = check_pose(g, p, q)
    R = quat_xyzw_to_matrix(q)
    B = p + g.ring_b_anchors @ R.T
    L = np.linalg.norm(B - g.ring_a_anchors, axis=1)
    inside = (L >= g.min_length) & (L <= g.max_length)
    np.testing.assert_array_equal(m.stroke >= 0, inside)
    np.testing.assert_allclose(np.abs(m.stroke), np.minimum(np.abs(L - g.min_length), np.abs(L - g.max_length)),
                               atol=1e-12)
    for k, (i, j) in enumerate(PAIRS):
        d = _brute_force_distance(g.ring_a_anchors[i], B[i], g.ring_a_anchors[j], B[j], n=201)
        assert m.segment_distances[k] <= d + 1e-12
        assert m.segment_distances[k] >= d - 0.01  # one sample step of the longest legs
    assert ok == bool(np.all(m.stroke >= 0) and np.all(m.universal >= 0) and np.all(m.spherical >= 0)
                      and np.all(m.interference >= 0) and m.conditioning >= 0)


def _assert_reference(m, ref):
    """Margins m (PoseMargins or a single pose's Margins) against the independent reference."""
    np.testing.assert_allclose(m.lengths, ref['lengths'], atol=1e-12)
    np.testing.assert_allclose(m.stroke, ref['stroke'], atol=1e-12)
    np.testing.assert_allclose(m.universal, ref['universal'], atol=1e-7)   # arccos near 0: ~1e-8
    np.testing.assert_allclose(m.spherical, ref['spherical'], atol=1e-7)
    np.testing.assert_allclose(m.interference, ref['interference'], atol=1e-12)
    assert m.inverse_condition == pytest.approx(ref['inverse_condition'], rel=1e-9)


@pytest.mark.parametrize('robot', ['pole_climber', 'frame_climber', 'facade_climber'])
def test_pose_margins_compiled_equals_the_reference(robot):
    """The compiled kernel, the same kernel interpreted and the batch margins give the numbers of
    an independent computation (rrps_testing.reference_limits: arccos, KKT, SVD)."""
    from rrps_description.rotations import rotation_vector_to_quat_xyzw
    from rrps_kinematics.limits import pose_margins
    from rrps_testing.reference_limits import reference_margins
    g = load_robot(robot)
    rng = np.random.default_rng(3)
    verdicts = set()
    for _ in range(200):
        p = g.home_position + rng.uniform(-0.25, 0.25, 3)  # inside and beyond the limits
        q = rotation_vector_to_quat_xyzw(rng.uniform(-0.6, 0.6, 3))
        fast, ref = pose_margins(g, p, q), pose_margins(g, p, q, backend='numpy')
        m = margins(g, inverse_kinematics(g, p, q))
        for a, b in zip(fast, ref):
            np.testing.assert_allclose(a, b, atol=1e-12)
        assert fast.minimum == pytest.approx({k: float(v) for k, v in m.minimum.items()}, abs=1e-12)
        assert fast.ok == ref.ok == m.ok
        independent = reference_margins(g, p, q)
        _assert_reference(fast, independent)
        _assert_reference(m, independent)
        if min(np.min(np.abs(independent[k])) for k in ('stroke', 'universal', 'spherical', 'interference')) > 1e-6:
            assert m.ok == (all(np.all(independent[k] >= 0) for k in ('stroke', 'universal', 'spherical',
                                                                     'interference'))
                            and independent['conditioning'] >= 0)
        verdicts.add(m.ok)
    assert verdicts == {True, False}  # both within and beyond the limits were tried
