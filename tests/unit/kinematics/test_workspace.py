"""The reachable workspace (rrps_kinematics.workspace) and ``rrps-kinematics workspace``."""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_xyzw_to_matrix, rotation_vector_to_matrix, rotation_vector_to_quat_xyzw
from rrps_kinematics import compiled_backend_available, inverse_kinematics, margins
from rrps_kinematics.cli import run
from rrps_kinematics.workspace import (
    LIMIT_KINDS,
    NEAR_SINGULAR,
    REACHABLE,
    SINGULAR_THRESHOLD,
    UNREACHABLE,
    automatic_bounds,
    distance_to_boundary,
    orientation_range,
    reachable_workspace,
)
from rrps_teleop.mapping import TeleopConfig
from rrps_testing.ci import require
from rrps_testing.reference_limits import KINDS, reference_margins

POLE = load_robot('pole_climber')
#: The pole climber with wide joint cones, a long stroke and thin legs: its workspace reaches
#: singular poses, so the conditioning limit and the near-singular set are exercised.
LOOSE = POLE.with_(universal_max_angle=math.pi, spherical_max_angle=math.pi, leg_radius=0.0,
                   min_length=0.05, max_length=0.6, min_conditioning=0.05)
ROBOTS = ('pole_climber', 'frame_climber', 'facade_climber', 'master_robot')


def grid_points(ws):
    return np.stack(np.meshgrid(*ws.axes, indexing='ij'), axis=-1).reshape(-1, 3)


#: Grid points checked against the independent limits beside the workspace's boundary cells (the
#: reference is plain Python, about 1 ms a pose).
SAMPLE = 600


def boundary_and_sample(labels: np.ndarray, n: int, seed: int = 7) -> np.ndarray:
    """Flat indices of the grid ``labels``: every cell whose label differs from a face neighbour's
    (where a wrong limit shows first), at most ``n`` of them, plus ``n`` others drawn at random."""
    edge = np.zeros(labels.shape, dtype=bool)
    for axis in range(labels.ndim):
        step = np.diff(labels, axis=axis) != 0
        lo = [slice(None)] * labels.ndim
        hi = [slice(None)] * labels.ndim
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        edge[tuple(lo)] |= step
        edge[tuple(hi)] |= step
    rng = np.random.default_rng(seed)
    boundary = np.flatnonzero(edge.ravel())
    boundary = rng.choice(boundary, min(n, len(boundary)), replace=False)
    others = np.setdiff1d(np.arange(labels.size), boundary)
    return np.sort(np.concatenate([boundary, rng.choice(others, min(n, len(others)), replace=False)]))


def reference(geometry, points, quaternions, threshold):
    """Labels and first broken limit of each point from limits.margins, pose by pose semantics."""
    labels = np.full(len(points), REACHABLE)
    first = np.full(len(points), -1)
    worst = np.full(len(points), np.inf)
    for q in np.atleast_2d(quaternions):
        m = margins(geometry, inverse_kinematics(geometry, points, np.broadcast_to(q, (len(points), 4))))
        broken = np.stack([~np.all(m.stroke >= 0, axis=-1), ~np.all(m.universal >= 0, axis=-1),
                           ~np.all(m.spherical >= 0, axis=-1), ~np.all(m.interference >= 0, axis=-1),
                           ~((m.conditioning >= 0) & (m.inverse_condition > 0))])
        assert np.array_equal(broken.any(axis=0), ~m.ok)
        new = (first < 0) & ~m.ok
        first[new] = np.argmax(broken[:, new], axis=0)
        labels[~m.ok] = UNREACHABLE
        worst = np.where(m.ok, np.minimum(worst, m.inverse_condition), worst)
    labels[(labels == REACHABLE) & (worst < threshold)] = NEAR_SINGULAR
    return labels, first


def independent(geometry, points, quaternions, threshold, tolerance=1e-6):
    """Labels and first broken limit of each point from rrps_testing.reference_limits (nothing of
    rrps_kinematics), and which points lie within ``tolerance`` of a limit or of the threshold
    (where two correct computations may round to different sides)."""
    labels = np.full(len(points), REACHABLE)
    first = np.full(len(points), -1)
    unsure = np.zeros(len(points), dtype=bool)
    for n, p in enumerate(points):
        worst = np.inf
        for q in np.atleast_2d(quaternions):
            ref = reference_margins(geometry, p, q)
            values = [np.min(ref[k]) for k in KINDS[:4]] + [min(ref['conditioning'], ref['inverse_condition'])]
            unsure[n] |= min(abs(v) for v in values) < tolerance
            broken = [not (v >= 0.0) for v in values]
            if any(broken):
                labels[n], first[n] = UNREACHABLE, broken.index(True)
                break
            worst = min(worst, ref['inverse_condition'])
        if labels[n] == REACHABLE:
            unsure[n] |= abs(worst - threshold) < tolerance
            if worst < threshold:
                labels[n] = NEAR_SINGULAR
    return labels, first, unsure


def test_default_threshold_is_the_teleop_slowdown():
    assert SINGULAR_THRESHOLD == TeleopConfig().singularity_slowdown


@settings(max_examples=40, deadline=None)
@given(robot=st.sampled_from([POLE, LOOSE]),
       rv=st.lists(st.floats(-0.4, 0.4), min_size=3, max_size=3),
       centre=st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3),
       threshold=st.floats(0.0, 0.3),
       backend=st.sampled_from(['auto', 'numpy']))
def test_classification_equals_the_margins(robot, rv, centre, threshold, backend):
    q = rotation_vector_to_quat_xyzw(np.array(rv))
    c = robot.home_position + np.array(centre)
    bounds = np.column_stack([c - 0.1, c + 0.1]).ravel()
    ws = reachable_workspace(robot, q, resolution=0.029, bounds=bounds, singular_threshold=threshold,
                             backend=backend)
    labels, first = reference(robot, grid_points(ws), q, threshold)
    np.testing.assert_array_equal(ws.labels.ravel(), labels)
    assert ws.excluded_by == {k: int(np.sum(first == i)) for i, k in enumerate(LIMIT_KINDS)}
    assert sum(ws.excluded_by.values()) == ws.counts['unreachable']
    labels, first, unsure = independent(robot, grid_points(ws), q, threshold)
    np.testing.assert_array_equal(ws.labels.ravel()[~unsure], labels[~unsure])


@pytest.mark.parametrize('name', ROBOTS)
def test_compiled_kernel_equals_the_numpy_path(name):
    require(compiled_backend_available(), 'numba is not available')
    g = load_robot(name)
    h = (g.max_length - g.min_length) / 8
    ranged = orientation_range(g.home_quaternion_xyzw, roll=(-0.2, 0.2), yaw=(-0.3, 0.3), step=0.2)
    for orientations in (None, rotation_vector_to_quat_xyzw(np.array([0.1, -0.2, 0.3])), ranged):
        a = reachable_workspace(g, orientations, resolution=h, singular_threshold=0.2, backend='numba')
        b = reachable_workspace(g, orientations, resolution=h, singular_threshold=0.2, backend='numpy')
        np.testing.assert_array_equal(a.labels, b.labels)
        assert a.excluded_by == b.excluded_by
        np.testing.assert_array_equal(a.origin, b.origin)
        checked = boundary_and_sample(a.labels, SAMPLE)
        labels, _, unsure = independent(g, grid_points(a)[checked], a.orientations, 0.2)
        assert np.mean(unsure) < 0.05
        np.testing.assert_array_equal(a.labels.ravel()[checked][~unsure], labels[~unsure])


def test_without_numba_the_numpy_path_gives_the_same_workspace():
    code = ('from rrps_description import load_robot\n'
            'from rrps_kinematics.workspace import reachable_workspace\n'
            'g = load_robot("pole_climber")\n'
            'ws = reachable_workspace(g, resolution=0.03)\n'
            'print(ws.counts["reachable"], ws.counts["total"])\n'
            'try:\n'
            '    reachable_workspace(g, resolution=0.03, backend="numba")\n'
            'except ValueError as exc:\n'
            '    print("refused:", exc)\n')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, RRPS_NUMBA='0'))
    assert out.returncode == 0, out.stderr
    counts, refused = out.stdout.splitlines()
    ws = reachable_workspace(POLE, resolution=0.03)
    assert counts == f'{ws.counts["reachable"]} {ws.counts["total"]}'
    assert refused.startswith('refused: backend "numba" requested')


@pytest.mark.parametrize('name', ROBOTS)
def test_home_is_reachable_and_far_points_are_not(name):
    g = load_robot(name)
    ws = reachable_workspace(g, resolution=(g.max_length - g.min_length) / 10)
    home = tuple(np.round((g.home_position - ws.origin) / ws.spacing).astype(int))
    assert ws.labels[home] != UNREACHABLE
    assert distance_to_boundary(ws, g.home_position) > 0.0
    # Every reachable point lies in the automatic bounds, and so within reach of every leg.
    lo, hi = automatic_bounds(g, g.home_quaternion_xyzw).reshape(3, 2).T
    assert np.all((ws.reachable >= lo) & (ws.reachable <= hi))
    far = g.home_position + [0.0, 0.0, 2.0 * g.max_length]
    assert distance_to_boundary(ws, far) < -g.max_length
    away = reachable_workspace(g, resolution=ws.spacing, bounds=[-0.1, 0.1, -0.1, 0.1, *(far[2] + [0, 0.1])])
    assert away.volume == 0.0 and away.counts['unreachable'] == away.counts['total'] > 0
    assert away.excluded_by['stroke'] == away.counts['total']
    assert distance_to_boundary(away, g.home_position) == -math.inf


def test_automatic_bounds_hold_the_workspace_of_a_larger_box():
    """A grid over the legs' full reach (balls of radius max_length) finds nothing outside them."""
    for orientations in (POLE.home_quaternion_xyzw, rotation_vector_to_quat_xyzw(np.array([0.3, 0.0, 0.4]))):
        R = quat_xyzw_to_matrix(orientations)
        centres = POLE.ring_a_anchors - POLE.ring_b_anchors @ R.T
        box = np.column_stack([centres.min(axis=0) - POLE.max_length,
                               centres.max(axis=0) + POLE.max_length]).ravel()
        wide = reachable_workspace(POLE, orientations, resolution=0.025, bounds=box)
        lo, hi = automatic_bounds(POLE, orientations).reshape(3, 2).T
        assert wide.volume > 0.0
        assert np.all((wide.reachable >= lo) & (wide.reachable <= hi))
        auto = reachable_workspace(POLE, orientations, resolution=0.025)
        assert auto.counts['total'] < wide.counts['total']
        assert auto.counts['reachable'] == pytest.approx(wide.counts['reachable'], rel=0.05)


def test_volume_converges_as_the_resolution_refines():
    coarse = reachable_workspace(POLE, resolution=0.02).volume
    fine = reachable_workspace(POLE, resolution=0.0125).volume
    assert coarse > 0.0
    assert abs(coarse - fine) / fine < 0.03


def test_a_scaled_copy_has_the_cube_of_the_volume():
    k = 0.25
    small = POLE.with_(ring_a_anchors=k * POLE.ring_a_anchors, ring_b_anchors=k * POLE.ring_b_anchors,
                       min_length=k * POLE.min_length, max_length=k * POLE.max_length,
                       leg_radius=k * POLE.leg_radius, home_position=None)
    big = reachable_workspace(POLE, resolution=0.02)
    little = reachable_workspace(small, resolution=k * 0.02)
    assert little.volume == pytest.approx(k ** 3 * big.volume, rel=0.01)
    assert distance_to_boundary(little, small.home_position) == pytest.approx(
        k * distance_to_boundary(big, POLE.home_position), rel=0.01)


def test_orientation_range_is_the_intersection_of_its_orientations():
    q0 = rotation_vector_to_quat_xyzw(np.array([0.0, 0.05, 0.1]))
    Q = orientation_range(q0, roll=(-0.15, 0.15), pitch=(0.0, 0.1), yaw=(-0.2, 0.2), step=0.15)
    total = reachable_workspace(POLE, Q, resolution=0.025, singular_threshold=0.2)
    singles = [reachable_workspace(POLE, q, resolution=0.025, bounds=total.bounds, singular_threshold=0.2)
               for q in Q]
    inside = np.stack([s.labels != UNREACHABLE for s in singles])
    near = np.stack([s.labels == NEAR_SINGULAR for s in singles])
    for s in singles:
        assert np.all(s.labels[total.labels != UNREACHABLE] != UNREACHABLE)  # a subset of each
    np.testing.assert_array_equal(total.labels != UNREACHABLE, inside.all(axis=0))
    np.testing.assert_array_equal(total.labels == NEAR_SINGULAR, inside.all(axis=0) & near.any(axis=0))
    assert 0.0 < total.volume < min(s.volume for s in singles)
    # The automatic bounds of the range hold the whole workspace of each of its orientations.
    for q, s in zip(Q[::4], singles[::4]):
        assert reachable_workspace(POLE, q, resolution=0.025).volume == s.volume


def test_orientation_range_samples():
    q0 = rotation_vector_to_quat_xyzw(np.array([0.1, 0.2, -0.3]))
    Q = orientation_range(q0, roll=(-0.1, 0.1), pitch=(0.2, 0.2), yaw=(0.0, 0.25), step=0.1)
    assert Q.shape == (3 * 1 * 4, 4)
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 1.0)
    # roll varies fastest; the last sample is every interval's maximum.
    expected = (rotation_vector_to_matrix([0, 0, 0.25]) @ rotation_vector_to_matrix([0, 0.2, 0])
                @ rotation_vector_to_matrix([0.1, 0, 0]) @ quat_xyzw_to_matrix(q0))
    np.testing.assert_allclose(quat_xyzw_to_matrix(Q[-1]), expected, atol=1e-12)
    yaws = [0.0, 0.25 / 3, 0.5 / 3, 0.25]
    first_of_each_yaw = quat_xyzw_to_matrix(Q[::3])
    for R, yaw in zip(first_of_each_yaw, yaws):
        e = (rotation_vector_to_matrix([0, 0, yaw]) @ rotation_vector_to_matrix([0, 0.2, 0])
             @ rotation_vector_to_matrix([-0.1, 0, 0]) @ quat_xyzw_to_matrix(q0))
        np.testing.assert_allclose(R, e, atol=1e-12)
    np.testing.assert_allclose(orientation_range(q0), q0[None])
    for kwargs, message in (({'roll': (0.2, 0.1)}, 'roll range'), ({'step': 0.0}, 'angle step'),
                            ({'yaw': (0.0, math.nan)}, 'yaw range'),
                            ({'yaw': (-3.0, 3.0), 'roll': (-3.0, 3.0), 'step': 0.01}, 'orientations >')):
        with pytest.raises(ValueError, match=message):
            orientation_range(q0, **kwargs)


def test_conditioning_and_the_near_singular_set():
    ws = reachable_workspace(LOOSE, resolution=0.04, singular_threshold=0.12)
    assert ws.excluded_by['conditioning'] > 0
    assert 0 < ws.counts['near_singular'] < ws.counts['reachable']
    assert ws.near_singular_volume == ws.counts['near_singular'] * 0.04 ** 3
    points = np.concatenate([ws.near_singular, ws.reachable])
    m = margins(LOOSE, inverse_kinematics(LOOSE, points, np.broadcast_to(LOOSE.home_quaternion_xyzw,
                                                                         (len(points), 4))))
    assert np.all(m.ok)
    n = len(ws.near_singular)
    assert np.all(m.inverse_condition[:n] < 0.12)
    assert np.sum(m.inverse_condition[n:] < 0.12) == n  # the near-singular points are reachable
    # The threshold moves points between the two sets, never in or out of the reachable set.
    for threshold, near in ((LOOSE.min_conditioning, 0), (1.0, ws.counts['reachable'])):
        other = reachable_workspace(LOOSE, resolution=0.04, singular_threshold=threshold)
        np.testing.assert_array_equal(other.labels != UNREACHABLE, ws.labels != UNREACHABLE)
        assert other.counts['near_singular'] == near


def test_distance_to_boundary_is_positive_inside_and_grows_towards_the_middle():
    ws = reachable_workspace(POLE, resolution=0.02)
    h = ws.spacing
    inside, outside = ws.reachable, ws.origin + h * np.argwhere(ws.labels == UNREACHABLE)
    d_in = distance_to_boundary(ws, inside)
    assert np.all(d_in >= h / 2 - 1e-12)
    assert np.all(distance_to_boundary(ws, outside) <= -h / 2 + 1e-12)
    # At grid points the distance transform is exact: the nearest unreachable point, minus h/2.
    rng = np.random.default_rng(0)
    for p in inside[rng.choice(len(inside), 20, replace=False)]:
        assert distance_to_boundary(ws, p) == pytest.approx(
            np.min(np.linalg.norm(outside - p, axis=1)) - h / 2, abs=1e-9)
    # Along rays from the deepest point the distance falls until the ray leaves the set (up to the
    # ripple of the trilinear interpolation between exact grid values).
    middle = inside[np.argmax(d_in)]
    assert distance_to_boundary(ws, POLE.home_position) > 0.9 * np.max(d_in) > 5 * h
    s = np.linspace(0.0, 0.5, 201)[:, None]
    for u in rng.normal(size=(50, 3)):
        d = distance_to_boundary(ws, middle + s * u / np.linalg.norm(u))
        leaves = int(np.argmax(d < 0.0))
        assert d[0] == np.max(d_in) and leaves > 0
        assert np.all(np.diff(d[:leaves + 1]) <= 0.1 * h)
        assert d[leaves] < d[leaves // 2] < d[0]
    # Beyond the grid it keeps falling.
    top = ws.bounds[5]
    assert (distance_to_boundary(ws, [0.0, 0.0, top + 1.0])
            < distance_to_boundary(ws, [0.0, 0.0, top + 0.5]) < 0.0)
    with pytest.raises(ValueError, match='NaN'):
        distance_to_boundary(ws, [0.0, math.nan, 0.4])
    with pytest.raises(ValueError, match='shape'):
        distance_to_boundary(ws, [0.0, 0.4])


@pytest.mark.parametrize('kwargs,message', [
    ({'resolution': 0.0}, 'resolution must be'),
    ({'resolution': math.inf}, 'resolution must be'),
    ({'resolution': 0.0005}, 'use a coarser resolution'),
    ({'bounds': [0, 1, 0, 1, 0]}, 'bounds must be 6'),
    ({'bounds': [0, 1, 0.5, 0.4, 0, 1]}, 'ymin 0.5 > ymax 0.4'),
    ({'singular_threshold': -0.1}, 'singular_threshold'),
    ({'singular_threshold': math.nan}, 'singular_threshold'),
    ({'orientations': [0, 0, 0, 0]}, 'zero norm'),
    ({'orientations': [[0, 0, 0]]}, 'shape'),
    ({'backend': 'fortran'}, 'backend must be one of'),
])
def test_bad_arguments_raise_value_error(kwargs, message):
    kwargs = {'resolution': 0.05, **kwargs}
    with pytest.raises(ValueError, match=message):
        reachable_workspace(POLE, **kwargs)


def test_unbounded_stroke_needs_bounds():
    free = POLE.with_(max_length=math.inf, home_position=None)
    with pytest.raises(ValueError, match='unbounded'):
        reachable_workspace(free, resolution=0.05)
    ws = reachable_workspace(free, resolution=0.05, bounds=[-0.2, 0.2, -0.2, 0.2, 0.2, 0.6])
    assert ws.shape == (9, 9, 9) and ws.volume > 0.0


# --- the command line ------------------------------------------------------------------------

def _run(capsys, *argv):
    code = run(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_writes_the_csvs_and_a_readable_png(capsys, tmp_path):
    import matplotlib.image

    csv, png = tmp_path / 'ws.csv', tmp_path / 'ws.png'
    code, out, err = _run(capsys, 'workspace', '--robot', 'pole_climber', '--quaternion', '0,0,0,1',
                          '--resolution', '0.02', '--roll', '-0.1,0.1', '--yaw', '-0.2,0.2',
                          '--angle-step', '0.1', '--singular-threshold', '0.2',
                          '--csv', str(csv), '--png', str(png))
    assert code == 0 and err == ''
    Q = orientation_range([0, 0, 0, 1], roll=(-0.1, 0.1), yaw=(-0.2, 0.2), step=0.1)
    ws = reachable_workspace(POLE, Q, resolution=0.02, singular_threshold=0.2)
    assert f'reachable: {ws.counts["reachable"]:,} points, volume {ws.volume:.6g} m^3' in out
    assert 'total-orientation workspace, 15 orientations' in out
    lines = csv.read_text().splitlines()
    assert lines[0] == 'x,y,z' and len(lines) == 1 + ws.counts['reachable']
    np.testing.assert_allclose(np.loadtxt(csv, delimiter=',', skiprows=1), ws.reachable, atol=1e-6)
    near = tmp_path / 'ws_near_singular.csv'
    assert near.read_text().splitlines()[0] == 'x,y,z'
    assert 0 < len(ws.near_singular) == len(np.loadtxt(near, delimiter=',', skiprows=1))
    image = matplotlib.image.imread(png)
    assert image.ndim == 3 and image.shape[0] > 200 and image.shape[1] > 600
    assert len(np.unique(image.reshape(-1, image.shape[2]), axis=0)) > 3  # not a blank picture


def test_cli_json_matches_the_library(capsys, tmp_path):
    code, out, err = _run(capsys, 'workspace', '--robot', 'master_robot', '--json',
                          '--bounds', '-0.05,0.05,-0.05,0.05,0.08,0.12',
                          '--near-singular-csv', str(tmp_path / 'near.csv'))
    assert code == 0 and err == ''
    data = json.loads(out)
    g = load_robot('master_robot')
    h = (g.max_length - g.min_length) / 25
    ws = reachable_workspace(g, resolution=h, bounds=[-0.05, 0.05, -0.05, 0.05, 0.08, 0.12])
    assert data['resolution_m'] == pytest.approx(h) and data['workspace'] == 'constant-orientation'
    assert data['volume_m3'] == pytest.approx(ws.volume) and data['excluded_by'] == ws.excluded_by
    assert data['reachable_points'] == ws.counts['reachable'] and data['csv'] is None
    assert data['shape'] == list(ws.shape) and data['bounds_m'][0] == -0.05
    assert data['home_distance_to_boundary_m'] == pytest.approx(distance_to_boundary(ws, g.home_position))
    assert (tmp_path / 'near.csv').read_text() == 'x,y,z\n'


@pytest.mark.parametrize('argv,message', [
    (['--resolution', '0'], 'argument --resolution: must be a positive number'),
    (['--resolution', '0.0001'], 'use a coarser resolution'),
    (['--bounds', '1,2,3'], 'argument --bounds: expected 6 numbers, got 3'),
    (['--bounds', '0.1,-0.1,0,1,0,1'], 'xmin 0.1 > xmax -0.1'),
    (['--roll', '0.2,0.1'], 'roll range must be finite with min <= max'),
    (['--yaw', '-3,3', '--pitch', '-3,3', '--angle-step', '0.01'], 'use a larger angle step'),
    (['--angle-step', '-0.1'], 'argument --angle-step: must be a positive number'),
    (['--singular-threshold', '2'], 'singular_threshold must be in [0, 1]'),
    (['--singular-threshold', 'x'], "argument --singular-threshold: invalid float value: 'x'"),
    (['--quaternion', '0,0,0,0'], 'quaternion has zero norm'),
    (['--csv', '/nonexistent/dir/ws.csv', '--resolution', '0.05'], 'cannot write'),
    (['--png', '/nonexistent/dir/ws.png', '--resolution', '0.05'], 'cannot write'),
    (['--robot', 'spider'], "unknown robot 'spider'"),
])
def test_cli_bad_arguments_give_one_line_and_status_2(capsys, argv, message):
    code, out, err = _run(capsys, 'workspace', *argv)
    assert code == 2 and out == ''
    assert len(err.strip().splitlines()) == 1
    assert err.startswith('rrps-kinematics: error: ') and message in err


def test_parallel_kernel_equals_the_serial_one(monkeypatch):
    require(compiled_backend_available(), 'numba is not available')
    ranged = orientation_range(LOOSE.home_quaternion_xyzw, roll=(-0.2, 0.2), step=0.2)
    parallel = reachable_workspace(LOOSE, ranged, resolution=0.02)
    assert parallel.labels.size >= 512 and parallel.counts['near_singular'] > 0
    monkeypatch.setattr('rrps_kinematics.workspace.PARALLEL_BATCH', 10 ** 12)
    serial = reachable_workspace(LOOSE, ranged, resolution=0.02)
    np.testing.assert_array_equal(parallel.labels, serial.labels)
    assert parallel.excluded_by == serial.excluded_by


def test_jacobi_inverse_condition_equals_the_svd():
    from rrps_kinematics.compiled_workspace import inverse_condition
    rng = np.random.default_rng(11)
    for k in range(300):
        J = rng.normal(size=(6, 6)) * rng.uniform(1e-3, 1e3, 6)   # columns of different scales
        if k % 3 == 0:
            J[:, 5] = J[:, 4] + 1e-4 * rng.normal(size=6)           # nearly singular
        sv = np.linalg.svd(J, compute_uv=False)
        assert inverse_condition(J.copy()) == pytest.approx(sv[5] / sv[0], rel=1e-9)
    assert inverse_condition(np.zeros((6, 6))) == 0.0
    assert inverse_condition(np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 0.5])) == pytest.approx(0.1, rel=1e-15)
