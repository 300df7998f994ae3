"""DAE dynamics of the 13-body model (paper section 2.3, eqs. 19-20) and its three integrators."""

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_description.world import STANDARD_GRAVITY
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.errors import ConvergenceError
from rrps_sim.dynamics import METHODS, MultibodyDynamics, SimulationResult, simulate
from rrps_sim.dynamics.bundles import new_workspace, workspace
from rrps_sim.dynamics.constraints import leg_blocks
from rrps_sim.dynamics.integrators import solve_dependent
from rrps_sim.dynamics.kernels import accelerations, multipliers

GEOM = load_robot('pole_climber')
POSITION = GEOM.home_position + np.array([0.01, -0.015, 0.02])
QUAT = rotation_vector_to_quat_xyzw(np.array([0.04, -0.03, 0.06]))
DYN = MultibodyDynamics(GEOM)
HOLD = DYN.holding_forces(POSITION, QUAT)
PUSH = HOLD + np.array([8.0, -5.0, 2.5, 6.0, -4.0, 1.5])


def moving_state(seed=0):
    """A consistent moving state: ring_b twist random, legs' velocities from Φ_q v = 0."""
    dyn = MultibodyDynamics(GEOM)
    dyn.reset(POSITION, QUAT)
    rng = np.random.default_rng(seed)
    v = np.zeros(78)
    v[0:6] = rng.normal(scale=[0.1, 0.1, 0.1, 0.5, 0.5, 0.5])
    q = dyn.q.copy()
    assert solve_dependent(q, v, dyn.parameters, 1e-13, 20) >= 0
    return dyn, q, v


def dense_eq19(dyn, q, v, forces):
    """The unstructured reference: assemble eq. 19 (150 x 150) and solve it densely."""
    n = 78
    M = np.zeros((n, n))
    F = np.zeros(n)
    for b in range(13):
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = dyn.mass[b] * np.eye(3)
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = dyn.inertia[b]
        w = v[6 * b + 3:6 * b + 6]
        F[6 * b:6 * b + 3] = dyn.mass[b] * np.array(STANDARD_GRAVITY)
        F[6 * b + 3:6 * b + 6] = -np.cross(w, dyn.inertia[b] @ w)
    Phi = np.zeros((72, n))
    gamma = np.zeros(72)
    B = np.empty((13, 18))
    g = np.empty(13)
    for k in range(6):
        leg_blocks(q, v, k, dyn.parameters.joints, dyn.parameters.support, B, g)
        cols = np.r_[0:6, 6 * (1 + 2 * k):6 * (1 + 2 * k) + 12]
        Phi[12 * k:12 * k + 12, cols] = B[:12]
        gamma[12 * k:12 * k + 12] = g[:12]
        h = B[12, 12:15]                      # the leg axis: driving row's ∂/∂r_upper
        F[6 * (1 + 2 * k):6 * (1 + 2 * k) + 3] -= forces[k] * h
        F[6 * (2 + 2 * k):6 * (2 + 2 * k) + 3] += forces[k] * h
    K = np.block([[M, Phi.T], [Phi, np.zeros((72, 72))]])
    x = np.linalg.solve(K, np.concatenate([F, gamma]))
    return x[:n], x[n:]


def test_structured_solve_of_eq19_equals_the_dense_solve():
    dyn, q, v = moving_state()
    acc = np.empty(78)
    lam = np.empty(72)
    ws = workspace(new_workspace())
    assert accelerations(q, v, PUSH, 0.0, 0.0, dyn.parameters, ws, acc)
    assert multipliers(dyn.parameters, ws, acc, lam)
    acc_ref, lam_ref = dense_eq19(dyn, q, v, PUSH)
    np.testing.assert_allclose(acc, acc_ref, atol=1e-9 * np.max(np.abs(acc_ref)))
    np.testing.assert_allclose(lam, lam_ref, atol=1e-9 * np.max(np.abs(lam_ref)))


def test_gamma_terms_keep_the_velocity_constraint_satisfied():
    # Φ_x v = 0 holds along the motion iff Φ_x acc = γ: check d/dt (Φ_x v) numerically.
    dyn, q, v = moving_state(1)
    acc = np.empty(78)
    assert accelerations(q, v, PUSH, 0.0, 0.0, dyn.parameters, workspace(new_workspace()), acc)
    B = np.empty((13, 18))
    g = np.empty(13)
    for k in range(6):
        leg_blocks(q, v, k, dyn.parameters.joints, dyn.parameters.support, B, g)
        idx = np.r_[0:6, 6 * (1 + 2 * k):6 * (1 + 2 * k) + 12]
        np.testing.assert_allclose(B[:12] @ v[idx], 0.0, atol=1e-12)
        np.testing.assert_allclose(B[:12] @ acc[idx], g[:12], atol=1e-9)


def test_holding_forces_satisfy_virtual_work():
    # Equilibrium: the actuators' virtual work f·δL equals the potential's increase δV.
    h = 1e-6
    for i in range(6):
        twist = np.zeros(6)
        twist[i] = h
        values = []
        for sign in (1.0, -1.0):
            position = POSITION + sign * twist[:3]
            quat = rotation_vector_to_quat_xyzw(sign * twist[3:] + np.array([0.04, -0.03, 0.06]))
            dyn = MultibodyDynamics(GEOM)
            dyn.reset(position, quat)
            values.append((inverse_kinematics(GEOM, position, quat).lengths, dyn.potential_energy))
        dL = values[0][0] - values[1][0]
        dV = values[0][1] - values[1][1]
        assert HOLD @ dL == pytest.approx(dV, abs=1e-8)


@pytest.mark.parametrize('method', METHODS)
def test_at_rest_under_holding_forces(method):
    res = simulate(GEOM, POSITION, QUAT, HOLD, duration=0.2, dt=0.002, method=method)
    assert np.max(np.abs(res.position - POSITION)) < 1e-10
    assert np.max(np.abs(res.length_rates)) < 1e-9
    assert np.max(np.abs(res.energy_balance)) < 1e-10


@pytest.mark.parametrize('method', METHODS)
def test_drift_norm_and_energy_bounds(method):
    res = simulate(GEOM, POSITION, QUAT, PUSH, duration=0.3, dt=0.001, method=method)
    assert isinstance(res, SimulationResult)
    assert res.t.shape == (301,) and res.position.shape == (301, 3)
    travel = np.max(np.linalg.norm(res.position - POSITION, axis=1))
    assert travel > 0.01                              # it really moves
    assert np.max(res.constraint_drift) < 1e-10
    assert np.max(res.euler_norm_error) < 1e-10
    scale = np.max(res.kinetic)
    assert scale > 0.1
    assert np.max(np.abs(res.energy_balance)) < 1e-8 * scale
    # energy bookkeeping: the balance is exactly the three terms
    np.testing.assert_allclose(res.energy_balance,
                               res.kinetic + res.potential - res.actuator_work
                               - res.kinetic[0] - res.potential[0], atol=1e-12)
    assert np.all(res.step_flops[1:] > 0) and np.all(res.step_seconds[1:] > 0)


def test_the_three_integrators_agree():
    ends = {m: simulate(GEOM, POSITION, QUAT, PUSH, duration=0.3, dt=0.002, method=m)
            for m in METHODS}
    for m in METHODS:
        np.testing.assert_allclose(ends[m].position[-1], ends['hybrid'].position[-1], atol=1e-9)
        np.testing.assert_allclose(ends[m].lengths[-1], ends['hybrid'].lengths[-1], atol=1e-9)


@pytest.mark.parametrize('method', ['hybrid', 'partitioning'])
def test_fourth_order_convergence_when_halving_the_step(method):
    def end(dt):
        return simulate(GEOM, POSITION, QUAT, PUSH, duration=0.4, dt=dt, method=method,
                        output_every=10**6).position[-1]
    ref = end(0.001)
    e1 = np.linalg.norm(end(0.008) - ref)
    e2 = np.linalg.norm(end(0.004) - ref)
    assert e2 < 1e-6
    assert 10.0 < e1 / e2 < 24.0                      # 2^4 = 16 for RK4


def test_baumgarte_pulls_a_constraint_violation_back():
    drifts = {}
    for gains in ((0.0, 0.0), (30.0, 30.0)):
        dyn = MultibodyDynamics(GEOM, 'baumgarte', alpha=gains[0], beta=gains[1])
        dyn.reset(POSITION, QUAT)
        q = dyn.q.copy()
        q[7 * 3:7 * 3 + 3] += 1e-5                     # open leg 1's universal joint
        dyn.set_state(q, dyn.v)
        start = dyn.constraint_drift
        for _ in range(300):
            dyn.step(HOLD, 0.001)
        drifts[gains] = dyn.constraint_drift / start
    assert drifts[(0.0, 0.0)] > 0.3
    assert drifts[(30.0, 30.0)] < 0.01


def test_hybrid_corrects_by_partitioning_when_drift_exceeds_tolerance():
    dyn = MultibodyDynamics(GEOM, 'hybrid', correction_tolerance=1e-12)
    dyn.reset(POSITION, QUAT)
    q = dyn.q.copy()
    q[7 * 3:7 * 3 + 3] += 1e-5
    q[3:7] *= 1.0 + 1e-6
    dyn.set_state(q, dyn.v)
    dyn.step(HOLD, 0.001)
    assert dyn.corrections == 1
    assert dyn.constraint_drift < 1e-13 and dyn.euler_norm_error < 1e-14
    clean = MultibodyDynamics(GEOM, 'hybrid')
    clean.reset(POSITION, QUAT)
    for _ in range(20):
        clean.step(PUSH, 0.001)
    assert clean.corrections == 0                       # drift stays below 1e-10 by itself


def test_state_api_and_callable_forces():
    seen = []
    fractions = []

    def forces(t, dyn):
        seen.append((t, dyn.lengths.copy()))
        return HOLD + 10.0 * np.sin(20.0 * t)

    res = simulate(GEOM, POSITION, QUAT, forces, duration=0.05, dt=0.001, output_every=10,
                   progress=fractions.append)
    assert res.t.shape == (6,)
    np.testing.assert_allclose(res.t, np.arange(6) * 0.01, atol=1e-12)
    assert len(seen) == 51 and seen[0][0] == 0.0
    assert fractions[-1] == 1.0 and np.all(np.diff(fractions) > 0)
    dyn = MultibodyDynamics(GEOM, 'partitioning')
    dyn.reset(POSITION, QUAT)
    np.testing.assert_allclose(dyn.lengths, inverse_kinematics(GEOM, POSITION, QUAT).lengths,
                               atol=1e-14)
    dyn.step(PUSH, 0.001)
    assert dyn.time == pytest.approx(0.001)
    assert np.all(np.abs(dyn.length_rates) > 0)
    assert dyn.quaternion_xyzw.shape == (4,) and dyn.position.shape == (3,)
    assert dyn.last_step_flops > 0


def test_bad_input():
    dyn = MultibodyDynamics(GEOM)
    with pytest.raises(ValueError, match='method'):
        MultibodyDynamics(GEOM, 'euler')
    with pytest.raises(ValueError, match='forces'):
        dyn.step(np.zeros(5), 0.001)
    with pytest.raises(ValueError, match='forces'):
        dyn.step([np.nan] * 6, 0.001)
    with pytest.raises(ValueError, match='dt'):
        dyn.step(HOLD, 0.0)
    with pytest.raises(ValueError, match='duration'):
        simulate(GEOM, POSITION, QUAT, HOLD, duration=-1.0)
    with pytest.raises(ValueError, match='output_every'):
        simulate(GEOM, POSITION, QUAT, HOLD, output_every=0)
    with pytest.raises(ValueError):
        simulate(GEOM, POSITION, [0, 0, 0, 0], HOLD)


def test_workspace_views_tile_the_buffer_without_overlap():
    buffer = new_workspace()
    ws = workspace(buffer)
    for i, field in enumerate(ws):
        field[...] = i
    sizes = [field.size for field in ws]
    assert sum(sizes) == buffer.size
    np.testing.assert_array_equal(buffer, np.repeat(np.arange(len(ws)), sizes))


@pytest.mark.parametrize('method', METHODS)
def test_a_compiled_run_equals_the_same_steps_taken_one_by_one(method):
    fractions = []
    batch = simulate(GEOM, POSITION, QUAT, PUSH, duration=0.05, dt=0.001, method=method,
                     output_every=3, progress=fractions.append)
    single = simulate(GEOM, POSITION, QUAT, lambda t, dyn: PUSH, duration=0.05, dt=0.001,
                      method=method, output_every=3)
    assert batch.t.shape == (18,) and fractions[-1] == 1.0 and np.all(np.diff(fractions) > 0)
    np.testing.assert_allclose(batch.t, single.t, rtol=0.0, atol=1e-15)
    for name in ('position', 'quaternion_xyzw', 'lengths', 'length_rates', 'forces',
                 'constraint_drift', 'euler_norm_error', 'energy_balance', 'actuator_work',
                 'step_flops'):
        np.testing.assert_array_equal(getattr(batch, name), getattr(single, name), err_msg=name)
    assert batch.corrections == single.corrections


def test_a_failed_run_raises_and_keeps_the_state_before_the_failing_step():
    throw = np.array([3000.0, 3000.0, 3000.0, -3000.0, -3000.0, -3000.0])
    dyn = MultibodyDynamics(GEOM, 'partitioning')
    with pytest.raises(ConvergenceError, match='no convergence'):
        dyn.run(throw, 0.001, 100)
    steps = int(round(dyn.time / 0.001))
    assert 0 < steps < 100
    ref = MultibodyDynamics(GEOM, 'partitioning')
    for _ in range(steps):
        ref.step(throw, 0.001)
    np.testing.assert_array_equal(dyn.q, ref.q)
    np.testing.assert_array_equal(dyn.v, ref.v)
    with pytest.raises(ConvergenceError):
        ref.step(throw, 0.001)
    np.testing.assert_array_equal(dyn.q, ref.q)         # a failed step changes nothing
