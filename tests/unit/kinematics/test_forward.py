"""Forward kinematics: IK o FK round trips, batches, both backends, failures reported not raised."""

import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.optimize import fsolve

from rrps_description.geometry import load_robot, shipped_robots
from rrps_description.rotations import (
    quat_multiply_xyzw,
    quat_xyzw_to_matrix,
    rotation_angle_between,
    rotation_vector_to_matrix,
    rotation_vector_to_quat_xyzw,
)
from rrps_kinematics import compiled_backend_available, forward_kinematics, inverse_kinematics, margins
from rrps_testing.ci import require

ROBOTS = {name: load_robot(name) for name in shipped_robots()}
BACKENDS = ['numpy'] + (['numba'] if compiled_backend_available() else [])


def _same_pose(fk, p, q, atol=1e-9):
    np.testing.assert_allclose(fk.position, p, atol=atol)
    angle = rotation_angle_between(quat_xyzw_to_matrix(fk.quaternion_xyzw), quat_xyzw_to_matrix(q))
    assert np.all(angle < atol)


def _workspace_sample(g, n, seed, *, within_limits=True):
    rng = np.random.default_rng(seed)
    P = g.home_position + rng.uniform(-0.5, 0.5, (n, 3)) * g.characteristic_length
    Q = rotation_vector_to_quat_xyzw(rng.uniform(-0.6, 0.6, (n, 3)))
    ik = inverse_kinematics(g, P, Q)
    keep = margins(g, ik).ok if within_limits else np.ones(n, dtype=bool)
    return P[keep], Q[keep], ik.lengths[keep]


def _fsolve_pose(g, L, seed_p, seed_q):
    """Independent FK: scipy.optimize.fsolve on |p + exp(v) R_seed b_i - a_i| - L_i = 0;
    (position, rotation, max |residual|)."""
    R0 = quat_xyzw_to_matrix(seed_q)

    def legs(x):
        R = rotation_vector_to_matrix(x[3:]) @ R0
        return np.linalg.norm(x[:3] + g.ring_b_anchors @ R.T - g.ring_a_anchors, axis=1) - L

    x = fsolve(legs, np.concatenate([seed_p, np.zeros(3)]), xtol=1e-14)
    return x[:3], rotation_vector_to_matrix(x[3:]) @ R0, float(np.max(np.abs(legs(x))))


def _agrees_with_fsolve(g, fk, L) -> bool:
    """Whether fsolve, seeded 1 mm and 0.01 rad from the pose FK found (the same assembly mode),
    finds a solution; when it does, it is FK's pose."""
    seed_q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.array([0.01, -0.005, 0.007])), fk.quaternion_xyzw)
    p, R, residual = _fsolve_pose(g, L, fk.position + [1e-3, -1e-3, 5e-4], seed_q)
    if residual > 1e-10:
        return False
    np.testing.assert_allclose(fk.position, p, atol=1e-9)
    assert rotation_angle_between(quat_xyzw_to_matrix(fk.quaternion_xyzw), R) < 1e-9
    return True


@st.composite
def workspace_poses(draw):
    name = draw(st.sampled_from(sorted(ROBOTS)))
    g = ROBOTS[name]
    dp = draw(arrays(np.float64, 3, elements=st.floats(-0.3, 0.3, allow_nan=False)))
    rv = draw(arrays(np.float64, 3, elements=st.floats(-0.4, 0.4, allow_nan=False)))
    return name, g.home_position + dp * g.characteristic_length, rotation_vector_to_quat_xyzw(rv)


@settings(max_examples=60, deadline=None)
@given(workspace_poses(), arrays(np.float64, 6, elements=st.floats(-1.0, 1.0, allow_nan=False)),
       st.sampled_from(BACKENDS))
def test_ik_fk_round_trip_from_previous_pose(pose, motion, backend):
    """FK seeded from the pose one control period earlier recovers the pose in a few steps."""
    name, p, q = pose
    g = ROBOTS[name]
    L = inverse_kinematics(g, p, q).lengths
    # The previous pose: up to 1 % of the ring radius and 0.02 rad away.
    seed_p = p - 0.01 * g.characteristic_length * motion[:3]
    seed_q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(0.02 * motion[3:]), q)
    fk = forward_kinematics(g, L, seed_p, seed_q, backend=backend)
    assert fk.converged and not fk.singular
    assert fk.iterations <= 4 and fk.residual <= 1e-12
    _same_pose(fk, p, q)
    assert fk.quaternion_xyzw[3] >= 0.0
    # IK of the result gives back the lengths.
    np.testing.assert_allclose(inverse_kinematics(g, fk.position, fk.quaternion_xyzw).lengths, L, atol=1e-12)


@pytest.mark.parametrize('name', sorted(ROBOTS))
@pytest.mark.parametrize('backend', BACKENDS)
def test_every_pose_within_limits_is_found_from_home(name, backend):
    g = ROBOTS[name]
    P, Q, L = _workspace_sample(g, 3000, 1)
    assert len(P) > 100
    fk = forward_kinematics(g, L, backend=backend)  # seeded at home
    assert np.all(fk.converged) and not np.any(fk.singular)
    _same_pose(fk, P, Q)


@pytest.mark.parametrize('name', sorted(ROBOTS))
def test_backends_compute_the_same_iterates(name):
    require(compiled_backend_available(), 'numba not available')
    g = ROBOTS[name]
    P, Q, L = _workspace_sample(g, 400, 2, within_limits=False)
    rng = np.random.default_rng(3)
    # Add unreachable and inconsistent lengths so that failures are compared too.
    L = np.vstack([L, rng.uniform(0.2, 3.0, (40, 6)) * g.home_lengths])
    a = forward_kinematics(g, L, backend='numpy')
    b = forward_kinematics(g, L, backend='numba')
    assert np.any(~a.converged) and np.any(a.converged)
    np.testing.assert_array_equal(a.converged, b.converged)
    np.testing.assert_array_equal(a.iterations, b.iterations)
    np.testing.assert_array_equal(a.singular, b.singular)
    ok = a.converged
    np.testing.assert_allclose(a.position[ok], b.position[ok], atol=1e-12)
    np.testing.assert_allclose(a.quaternion_xyzw[ok], b.quaternion_xyzw[ok], atol=1e-12)
    np.testing.assert_allclose(a.residual[ok], b.residual[ok], atol=1e-12)
    # Independently of the kernel: the lengths of the pose found, and fsolve's solution.
    legs = (b.position[:, None, :] + np.einsum('nkj,ij->nik', quat_xyzw_to_matrix(b.quaternion_xyzw),
                                               g.ring_b_anchors) - g.ring_a_anchors)
    assert np.all(np.abs(np.linalg.norm(legs, axis=-1) - L)[b.converged] <= 1e-12)
    found = [_agrees_with_fsolve(g, forward_kinematics(g, L[k]), L[k]) for k in np.flatnonzero(ok)[:40]]
    assert np.mean(found) > 0.9


@pytest.mark.parametrize('backend', BACKENDS)
def test_batch_equals_single(backend):
    g = ROBOTS['frame_climber']
    P, Q, L = _workspace_sample(g, 400, 4)
    seeds_p = P + 0.01
    seeds_q = np.tile(g.home_quaternion_xyzw, (len(P), 1))
    batch = forward_kinematics(g, L, seeds_p, seeds_q, backend=backend)
    assert batch.position.shape == (len(P), 3) and batch.converged.shape == (len(P),)
    for k in range(0, len(P), 7):
        single = forward_kinematics(g, L[k], seeds_p[k], seeds_q[k], backend=backend)
        assert single.converged == batch.converged[k]
        assert single.iterations == batch.iterations[k]
        np.testing.assert_allclose(single.position, batch.position[k], atol=1e-13)
        np.testing.assert_allclose(single.quaternion_xyzw, batch.quaternion_xyzw[k], atol=1e-13)
    # Seeds broadcast; a (2, k, 6) batch keeps its shape.
    two = forward_kinematics(g, L[:6].reshape(2, 3, 6), g.home_position, backend=backend)
    assert two.position.shape == (2, 3, 3) and two.iterations.shape == (2, 3)
    np.testing.assert_allclose(two.position.reshape(6, 3), P[:6], atol=1e-9)


@pytest.mark.parametrize('backend', BACKENDS)
def test_impossible_lengths_are_reported_not_raised(backend):
    g = ROBOTS['pole_climber']
    L = g.home_lengths.copy()
    L[0], L[1] = 0.05, 1.5  # two legs with neighbouring anchors cannot differ by that much
    fk = forward_kinematics(g, L, backend=backend)
    assert not fk.converged and fk.residual > 1e-3
    assert isinstance(fk.converged, bool) and isinstance(fk.iterations, int)
    assert np.all(np.isfinite(fk.position)) and np.isclose(np.linalg.norm(fk.quaternion_xyzw), 1.0)


@pytest.mark.parametrize('backend', BACKENDS)
def test_singular_jacobian_is_reported_not_raised(backend):
    g = ROBOTS['pole_climber']
    pinned = g.with_(ring_b_anchors=np.zeros((6, 3)))  # every leg ends at ring_b's origin
    fk = forward_kinematics(pinned, pinned.home_lengths * 1.01, backend=backend)
    assert fk.singular and not fk.converged
    batch = forward_kinematics(pinned, np.tile(pinned.home_lengths, (3, 1)) * [[1.01], [1.0], [0.99]],
                               backend=backend)
    np.testing.assert_array_equal(batch.singular, [True, False, True])
    np.testing.assert_array_equal(batch.converged, [False, True, False])  # the seed was exact


@pytest.mark.parametrize('backend', BACKENDS)
def test_iteration_budget_is_respected(backend):
    g = ROBOTS['pole_climber']
    p = g.home_position + [0.03, -0.02, 0.05]
    q = rotation_vector_to_quat_xyzw([0.2, 0.1, -0.3])
    L = inverse_kinematics(g, p, q).lengths
    none = forward_kinematics(g, L, max_iterations=0, backend=backend)
    assert not none.converged and none.iterations == 0
    np.testing.assert_allclose(none.position, g.home_position)
    one = forward_kinematics(g, L, max_iterations=1, backend=backend)
    assert one.iterations == 1 and one.residual < none.residual
    loose = forward_kinematics(g, L, tolerance=1e-4, backend=backend)
    assert loose.converged and loose.iterations < forward_kinematics(g, L, backend=backend).iterations


@pytest.mark.parametrize('kwargs,message', [
    ({'lengths': [0.4] * 5}, 'lengths must have shape'),
    ({'lengths': [0.4] * 5 + [np.nan]}, 'NaN'),
    ({'seed_position': [0, 0]}, 'seed shapes'),
    ({'seed_quaternion_xyzw': [0, 0, 0, 0]}, 'zero norm'),
    ({'seed_position': [0, 0, np.inf]}, 'NaN or infinite'),
    ({'tolerance': 0.0}, 'tolerance'),
    ({'max_iterations': -1}, 'max_iterations'),
    ({'backend': 'fortran'}, 'backend must be one of'),
])
@pytest.mark.parametrize('backend', BACKENDS)
def test_bad_input_raises_value_error(kwargs, message, backend):
    g = ROBOTS['pole_climber']
    args = {'lengths': g.home_lengths, 'backend': backend, **kwargs}
    with pytest.raises(ValueError, match=message):
        forward_kinematics(g, **args)


def test_numpy_only_when_numba_is_disabled():
    code = ('import numpy as np; from rrps_kinematics import *; from rrps_description import load_robot; '
            'g = load_robot("master_robot"); '
            'print(compiled_backend_available(), forward_kinematics(g, g.home_lengths * 1.01).converged)')
    env = dict(os.environ, RRPS_NUMBA='0')
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ['False', 'True']
    code_numba = code.replace('forward_kinematics(g, g.home_lengths * 1.01)',
                              'forward_kinematics(g, g.home_lengths, backend="numba")')
    out = subprocess.run([sys.executable, '-c', code_numba], env=env, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode != 0 and 'numba is not available' in out.stderr


@pytest.mark.parametrize('backend', BACKENDS)
def test_overflowing_seed_is_reported_not_raised(backend):
    g = ROBOTS['pole_climber']
    fk = forward_kinematics(g, g.home_lengths, [1e300, 0.0, 0.0], backend=backend)
    assert not fk.converged and fk.residual == np.inf and fk.iterations == 0


def _serial_batches(monkeypatch):
    """Below PARALLEL_BATCH every batch kernel runs serially: the reference of the parallel ones."""
    for module in ('forward', 'inverse', 'workspace'):
        monkeypatch.setattr(f'rrps_kinematics.{module}.PARALLEL_BATCH', 10 ** 12)


def test_parallel_batches_equal_the_serial_kernels_bit_for_bit(monkeypatch):
    require(compiled_backend_available(), 'numba not available')
    from rrps_kinematics import leg_lengths
    from rrps_kinematics.backend import PARALLEL_BATCH
    g = ROBOTS['pole_climber']
    P, Q, L = _workspace_sample(g, 3 * PARALLEL_BATCH, 7, within_limits=False)
    L = np.vstack([L, np.random.default_rng(8).uniform(0.2, 3.0, (40, 6)) * g.home_lengths])
    seeds_p = np.resize(P + 0.01, (len(L), 3))
    assert len(L) >= PARALLEL_BATCH
    parallel = forward_kinematics(g, L, seeds_p, g.home_quaternion_xyzw)
    lengths = leg_lengths(g, P, Q)
    _serial_batches(monkeypatch)
    serial = forward_kinematics(g, L, seeds_p, g.home_quaternion_xyzw)
    assert np.any(serial.converged) and np.any(~serial.converged)
    for a, b in zip(parallel, serial):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(lengths, leg_lengths(g, P, Q))


@pytest.mark.parametrize('name', sorted(ROBOTS))
def test_numpy_single_solve_follows_the_compiled_iterates(name):
    """The kernel interpreted (the fallback) takes the compiled kernel's steps, to fsolve's pose."""
    require(compiled_backend_available(), 'numba not available')
    g = ROBOTS[name]
    P, Q, L = _workspace_sample(g, 60, 9, within_limits=False)
    L = np.vstack([L, np.random.default_rng(10).uniform(0.2, 3.0, (10, 6)) * g.home_lengths])
    found = 0
    for k, lengths in enumerate(L):
        a = forward_kinematics(g, lengths, backend='numpy')
        b = forward_kinematics(g, lengths, backend='numba')
        assert (a.converged, a.iterations, a.singular) == (b.converged, b.iterations, b.singular)
        if a.converged:
            np.testing.assert_allclose(a.position, b.position, atol=1e-14)
            np.testing.assert_allclose(a.quaternion_xyzw, b.quaternion_xyzw, atol=1e-14)
            found += _agrees_with_fsolve(g, a, lengths)
    assert found >= 20


@pytest.mark.parametrize('backend', BACKENDS)
def test_forward_solver_takes_any_array_like_input(backend):
    """The stream solver's fast path refuses nothing a user may pass: other dtypes, strided or
    read-only arrays and lists give the same pose; bad values raise as forward_kinematics."""
    from rrps_kinematics import ForwardSolver
    g = ROBOTS['frame_climber']
    p = g.home_position + [0.01, -0.02, 0.015]
    q = rotation_vector_to_quat_xyzw([0.05, -0.03, 0.08])
    L = inverse_kinematics(g, p, q).lengths
    solver = ForwardSolver(g, backend=backend)
    reference = solver(L, g.home_position, g.home_quaternion_xyzw)
    _same_pose(reference, p, q)
    frozen = L.copy()
    frozen.flags.writeable = False
    strided = np.repeat(L, 2)[::2]
    for lengths in (list(L), frozen, strided, L.astype(np.longdouble), L.reshape(1, 6)[0]):
        fk = solver(lengths, list(g.home_position), np.asarray(g.home_quaternion_xyzw) * 3.0)
        np.testing.assert_allclose(fk.position, reference.position, atol=1e-12)
    assert solver(L).iterations == reference.iterations  # the home seed by default
    for bad, message in (([0.4] * 5, 'lengths must have shape'), (np.full(6, np.nan), 'NaN'),
                         (np.arange(12.0).reshape(2, 6), None)):
        if message is None:
            assert solver(bad).position.shape == (2, 3)   # a batch, not an error
            continue
        with pytest.raises(ValueError, match=message):
            solver(np.asarray(bad, dtype=float))
    with pytest.raises(ValueError, match='NaN or infinite'):
        solver(L, np.array([0.0, np.inf, 0.0]))
    with pytest.raises(ValueError, match='zero norm'):
        solver(L, None, np.zeros(4))
    with pytest.raises(ValueError, match='tolerance'):
        ForwardSolver(g, tolerance=-1.0)
