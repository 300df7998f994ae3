"""The Study-coordinate system, its shipped generic solutions and the path tracker (homotopy.py).

The system is checked against an independent evaluation written here (quaternion products of
the leg closure, finite differences for the derivatives), and the shipped start solutions against
that evaluation and a monodromy loop.
"""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_kinematics.backend import numba_enabled
from rrps_testing.ci import require

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope='module')
def H():
    require(numba_enabled(), 'the continuation needs numba')
    from rrps_kinematics import homotopy
    return homotopy


@pytest.fixture(scope='module')
def S():
    from rrps_kinematics import study_start
    return study_start


def _qmul(p, q):
    """Quaternion product (w, x, y, z) written out, for complex arrays (..., 4)."""
    w1, x1, y1, z1 = np.moveaxis(p, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(q, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def _system(x, P, chart):
    """The 8 equations: |e b - a e + g|^2 - L^2 e.e (6), e.g, c.x - 1, by quaternion products."""
    e, g = x[:4], x[4:]
    pure = np.concatenate([np.zeros((6, 1)), P[:, :3]], axis=1), np.concatenate([np.zeros((6, 1)), P[:, 3:6]], axis=1)
    u = _qmul(e, pure[1]) - _qmul(pure[0], e) + g
    return np.concatenate([np.sum(u * u, axis=1) - P[:, 6] * (e @ e), [e @ g, chart @ x - 1.0]])


def _run(H, X, P0, P1, gamma, chart):
    n = len(X)
    status, reached, steps = np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros(n, dtype=np.int64)
    H.track_all(X, P0, P1, gamma, chart, 1e-9, 0.2, 5000, 1e-10, 0.0, status, reached, steps)
    return status


def test_start_solutions_solve_the_start_system(S):
    X = S.SOLUTIONS
    assert X.shape == (40, 8) and S.PARAMETERS.shape == (6, 7) and S.CHART.shape == (8,)
    residual = max(np.max(np.abs(_system(x, S.PARAMETERS, S.CHART))) for x in X)
    assert residual < 1e-10
    distance = np.linalg.norm(X[:, None] - X[None], axis=2) + np.eye(40)
    assert distance.min() > 1e-3
    ratio = np.abs(np.sum(X[:, :4] ** 2, axis=1)) / np.sum(np.abs(X) ** 2, axis=1)
    assert ratio.min() > 1e-6                              # none near e.e = 0


def test_start_data_come_from_the_generator_script(S):
    """The shipped system is the one the script draws for its recorded seed."""
    spec = importlib.util.spec_from_file_location('generate_study_start', ROOT / 'tools/generate_study_start.py')
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    P, chart, x0 = script.generic_system(np.random.default_rng(S.SEED))
    # the script's arithmetic rounds in the last bit differently on other CPUs and BLAS builds
    np.testing.assert_allclose(P, S.PARAMETERS, rtol=1e-13, atol=0)
    np.testing.assert_allclose(chart, S.CHART, rtol=1e-13, atol=0)
    assert np.max(np.abs(_system(x0, P, chart))) < 1e-12


def test_monodromy_loop_finds_no_new_solution(H, S):
    """Tracking the 40 solutions around a loop in parameter space permutes them: no 41st."""
    rng = np.random.default_rng(7)
    X = S.SOLUTIONS.copy()
    P1, P2 = (rng.standard_normal((2, 6, 7)) + 1j * rng.standard_normal((2, 6, 7))) / np.sqrt(2)
    for A, B, gamma in ((S.PARAMETERS, P1, 0.3 + 0.8j), (P1, P2, -0.6 + 0.2j), (P2, S.PARAMETERS, 0.9 - 0.4j)):
        assert np.all(_run(H, X, A, B, gamma, S.CHART) == H.TRACKED)
    distance = np.linalg.norm(X[:, None] - S.SOLUTIONS[None], axis=2)
    match = np.argmin(distance, axis=1)
    assert np.max(np.min(distance, axis=1)) < 1e-8
    assert sorted(match) == list(range(40))


def test_jacobian_and_parameter_derivative_match_finite_differences(H, S):
    rng = np.random.default_rng(3)
    x = S.SOLUTIONS[5] + 0.1 * (rng.standard_normal(8) + 1j * rng.standard_normal(8))
    dP = rng.standard_normal((6, 7)) + 1j * rng.standard_normal((6, 7))
    F, Ft, J = np.zeros(8, complex), np.zeros(8, complex), np.zeros((8, 8), complex)
    H.study_system(x, S.PARAMETERS, dP, S.CHART, F, J, Ft, np.zeros((4, 4), complex),
                   np.zeros((4, 4), complex), np.zeros(4, complex))
    np.testing.assert_allclose(F, _system(x, S.PARAMETERS, S.CHART), atol=1e-12)
    h = 1e-6
    for k in range(8):
        dx = np.zeros(8, complex)
        dx[k] = h
        fd = (_system(x + dx, S.PARAMETERS, S.CHART) - _system(x - dx, S.PARAMETERS, S.CHART)) / (2 * h)
        np.testing.assert_allclose(J[:, k], fd, atol=1e-7)
    fd = (_system(x, S.PARAMETERS + h * dP, S.CHART) - _system(x, S.PARAMETERS - h * dP, S.CHART)) / (2 * h)
    np.testing.assert_allclose(Ft, fd, atol=1e-7)


def test_a_real_pose_solves_the_robots_study_system():
    """x = (e, r e) of a pose solves the system with the lengths of eq. 1 computed here."""
    from rrps_kinematics.homotopy_run import study_parameters
    g = load_robot('pole_climber')
    q = np.array([0.1, -0.2, 0.3, 0.9])
    q /= np.linalg.norm(q)
    r = g.home_position + [0.01, -0.02, 0.03]
    L = np.linalg.norm(r + g.ring_b_anchors @ quat_xyzw_to_matrix(q).T - g.ring_a_anchors, axis=1)
    s = g.characteristic_length
    e = np.r_[q[3], q[:3]].astype(complex)
    x = np.concatenate([e, _qmul(np.r_[0.0, r / s], e)])
    chart = np.r_[1.0, np.zeros(7)] / e[0]
    assert np.max(np.abs(_system(x, study_parameters(g, L), chart))) < 1e-12


def test_one_compiled_signature_serves_every_caller(H, S):
    """The warm-up's call (assembly_modes) compiles what the tests and the generator call too."""
    from rrps_kinematics import assembly_modes
    g = load_robot('pole_climber')
    assembly_modes(g, g.home_lengths)
    _run(H, S.SOLUTIONS[:2].copy(), S.PARAMETERS, S.PARAMETERS * 1.01, 0.6 + 0.8j, S.CHART)
    assert len(H.track_all.signatures) == 1
