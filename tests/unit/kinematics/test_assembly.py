"""assembly_modes: every real forward-kinematics solution, by continuation and by multi-start."""

import itertools

import numpy as np
import pytest

from rrps_description.geometry import RobotGeometry, load_robot
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_angle_between
from rrps_kinematics import assembly_modes, compiled_backend_available, inverse_kinematics
from rrps_kinematics.assembly import halton
from rrps_kinematics.backend import numba_enabled
from rrps_testing.ci import require

# Dietmaier's platform (P. Dietmaier, "The Stewart-Gough platform of general geometry can have
# 40 real postures", Advances in Robot Kinematics: Analysis and Control, 1998, pp. 7-16), with
# the six-digit data as published in the CuikSuite documentation
# (www-iri.upc.es/people/porta/Soft/CuikSuite2-Doc, "Dietmeier.world"): base points A_i,
# platform points B_i (platform frame) and leg lengths.
DIETMAIER_A = np.array([
    [0.0, 0.0, 0.0],
    [1.107915, 0.0, 0.0],
    [0.549094, 0.756063, 0.0],
    [0.735077, -0.223935, 0.525991],
    [0.514188, -0.526063, -0.368418],
    [0.590473, 0.094733, -0.205018],
])
DIETMAIER_B = np.array([
    [0.0, 0.0, 0.0],
    [0.542805, 0.0, 0.0],
    [0.956919, -0.528915, 0.0],
    [0.665885, -0.353482, 1.402538],
    [0.478359, 1.158742, 0.107672],
    [-0.137087, -0.235121, 0.353913],
])
DIETMAIER_L = np.array([1.0, 0.645275, 1.086284, 1.503439, 1.281933, 0.771071])


def _distinct(modes, scale):
    for i, j in itertools.combinations(range(len(modes)), 2):
        dp = np.linalg.norm(modes.positions[i] - modes.positions[j]) / scale
        da = rotation_angle_between(quat_xyzw_to_matrix(modes.quaternions_xyzw[i]),
                                    quat_xyzw_to_matrix(modes.quaternions_xyzw[j]))
        assert dp + da > 1e-4, (i, j)


def _same_set(a, b, atol):
    """Every mode of a matches one of b (and the counts agree) to atol in position and quaternion."""
    assert len(a) == len(b)
    for p, q in zip(a.positions, a.quaternions_xyzw):
        k = np.argmin(np.linalg.norm(b.positions - p, axis=1) + np.linalg.norm(b.quaternions_xyzw - q, axis=1))
        np.testing.assert_allclose(b.positions[k], p, atol=atol)
        np.testing.assert_allclose(b.quaternions_xyzw[k], q, atol=atol)


def _continuation_required():
    require(numba_enabled(), 'the continuation needs numba')


def test_dietmaier_platform_has_all_40_real_postures():
    """Dietmaier's published example (data looked up, not constructed: see DIETMAIER_* above,
    six-digit values from the CuikSuite documentation of Dietmaier 1998): 40 real solutions,
    the maximum of the 40 complex ones.

    The continuation tracks all 40 paths to their end (certified) and every endpoint is real;
    40 distinct poses, each reproducing the lengths by IK to 1e-9 m, prove that none is missing.
    The multi-start search (another method) finds the same set; run twice for determinism.
    """
    _continuation_required()
    g = RobotGeometry(ring_a_anchors=DIETMAIER_A, ring_b_anchors=DIETMAIER_B, name='dietmaier')
    modes = assembly_modes(g, DIETMAIER_L)
    assert len(modes) == 40 and modes.certified and modes.paths_failed == 0
    assert modes.method == 'continuation' and modes.seeds == 0 and np.all(modes.hits == 1)
    assert np.all(modes.residuals <= 1e-9)
    lengths = inverse_kinematics(g, modes.positions, modes.quaternions_xyzw).lengths
    np.testing.assert_allclose(lengths, np.broadcast_to(DIETMAIER_L, (40, 6)), atol=1e-9)
    _distinct(modes, g.characteristic_length)
    multistart = assembly_modes(g, DIETMAIER_L, method='multistart')
    assert multistart.method == 'multistart' and not multistart.certified and multistart.seeds == 20000
    _same_set(modes, multistart, 1e-9)
    again = assembly_modes(g, DIETMAIER_L)
    np.testing.assert_array_equal(again.positions, modes.positions)
    np.testing.assert_array_equal(again.quaternions_xyzw, modes.quaternions_xyzw)


@pytest.mark.parametrize('robot', ['pole_climber', 'master_robot', 'facade_climber', 'frame_climber'])
def test_shipped_robots_continuation_matches_multistart(robot):
    """At home lengths and at lengths changed by a few percent: certified, and the same set as
    the multi-start search."""
    _continuation_required()
    g = load_robot(robot)
    for L in (g.home_lengths, g.home_lengths * [1.03, 0.98, 1.01, 1.0, 0.97, 1.02]):
        modes = assembly_modes(g, L)
        assert modes.certified and modes.paths_failed == 0 and len(modes) >= 2
        _same_set(modes, assembly_modes(g, L, method='multistart', n_seeds=6000), 1e-9)


def test_random_robots_continuation_matches_multistart():
    """Random anchors (every other robot with planar rings) and the lengths of a random pose:
    certified (a second or third gamma may be needed), and the same set as the multi-start."""
    _continuation_required()
    rng = np.random.default_rng(1)
    for k in range(4):
        A, B = rng.uniform(-1, 1, (6, 3)), rng.uniform(-0.7, 0.7, (6, 3))
        if k % 2:
            A[:, 2] = B[:, 2] = 0.0
        q = rng.normal(size=4)
        p = rng.uniform(-0.5, 0.5, 3) + [0.0, 0.0, 1.0]
        L = np.linalg.norm(p + B @ quat_xyzw_to_matrix(q / np.linalg.norm(q)).T - A, axis=1)
        g = RobotGeometry(ring_a_anchors=A, ring_b_anchors=B, name=f'random_{k}')
        modes = assembly_modes(g, L)
        assert modes.certified and modes.method == 'continuation'
        _same_set(modes, assembly_modes(g, L, method='multistart'), 1e-9)


def test_without_numba_the_multistart_runs():
    g = load_robot('master_robot')
    modes = assembly_modes(g, g.home_lengths, n_seeds=1500, backend='numpy')
    assert modes.method == 'multistart' and not modes.certified and modes.seeds == 1500
    _same_set(modes, assembly_modes(g, g.home_lengths, method='multistart', n_seeds=1500, backend='numpy'), 0.0)


def test_failed_paths_bring_in_the_multistart(monkeypatch):
    """Paths that cannot end (here: at most 3 steps each) make the result uncertified and add
    the multi-start's modes."""
    _continuation_required()
    from rrps_kinematics import homotopy_run
    monkeypatch.setattr(homotopy_run, 'MAX_STEPS', 3)
    g = load_robot('pole_climber')
    modes = assembly_modes(g, g.home_lengths, n_seeds=4000)
    assert not modes.certified and modes.paths_failed == 40 and modes.method == 'continuation+multistart'
    assert modes.seeds == 4000
    _same_set(modes, assembly_modes(g, g.home_lengths, method='multistart', n_seeds=4000), 1e-12)


def test_home_pose_is_the_first_mode_and_planar_rings_mirror():
    g = load_robot('pole_climber')
    modes = assembly_modes(g, g.home_lengths, n_seeds=4000)
    assert len(modes) >= 2 and len(modes) % 2 == 0
    np.testing.assert_allclose(modes.positions[0], g.home_position, atol=1e-9)
    assert rotation_angle_between(np.eye(3), quat_xyzw_to_matrix(modes.quaternions_xyzw[0])) < 1e-9
    # Both rings' anchors lie in their z = 0 planes, so reflecting a solution through ring_a's
    # plane (p -> S p, R -> S R S, S = diag(1, 1, -1)) gives another solution.
    S = np.diag([1.0, 1.0, -1.0])
    R = quat_xyzw_to_matrix(modes.quaternions_xyzw)
    for p, r in zip(modes.positions, R):
        mp, mr = S @ p, S @ r @ S
        match = [np.linalg.norm(mp - p2) < 1e-7 and rotation_angle_between(mr, r2) < 1e-7
                 for p2, r2 in zip(modes.positions, R)]
        assert sum(match) == 1


def test_backends_find_the_same_modes():
    require(compiled_backend_available(), 'numba not available')
    g = load_robot('master_robot')
    L = g.home_lengths * [1.05, 0.97, 1.02, 1.0, 0.95, 1.03]
    a = assembly_modes(g, L, method='multistart', n_seeds=1500, backend='numpy')
    b = assembly_modes(g, L, method='multistart', n_seeds=1500, backend='numba')
    assert len(a) == len(b) > 0
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-10)
    np.testing.assert_allclose(a.quaternions_xyzw, b.quaternions_xyzw, atol=1e-10)
    np.testing.assert_array_equal(a.hits, b.hits)


def test_no_real_solution_gives_no_modes():
    g = load_robot('master_robot')
    L = g.home_lengths.copy()
    L[0], L[1] = 0.01, 0.5
    for method in ('continuation', 'multistart'):
        modes = assembly_modes(g, L, method=method, n_seeds=500)
        assert len(modes) == 0 and modes.positions.shape == (0, 3)


def test_halton_sequence():
    h = halton(4, 2)
    np.testing.assert_allclose(h[:, 0], [1 / 2, 1 / 4, 3 / 4, 1 / 8])
    np.testing.assert_allclose(h[:, 1], [1 / 3, 2 / 3, 1 / 9, 4 / 9])
    assert np.all((halton(1000) >= 0) & (halton(1000) < 1))


@pytest.mark.parametrize('lengths,kwargs,message', [
    ([0.4] * 5, {}, 'shape'),
    ([[0.4] * 6] * 2, {}, r'shape \(6,\)'),
    ([0.4] * 5 + [-0.1], {}, 'positive'),
    ([0.4] * 5 + [np.nan], {}, 'NaN'),
    ([0.4] * 6, {'n_seeds': 0}, 'n_seeds'),
    ([0.4] * 6, {'method': 'bezout'}, 'method'),
    ([0.4] * 5 + [np.inf], {'method': 'multistart'}, 'NaN'),
])
def test_bad_input(lengths, kwargs, message):
    with pytest.raises(ValueError, match=message):
        assembly_modes(load_robot('pole_climber'), lengths, **kwargs)
