"""numba is optional: with ``RRPS_NUMBA=0`` the multibody model and the dynamics run their kernels
as plain Python (numba is never imported) and give the compiled path's numbers.

The flag is read once per process, so the pure-Python side runs in a subprocess: it imports this
module and calls :func:`compute`, the parent compares with the same function run compiled.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.backend import numba_enabled
from rrps_kinematics.multibody import MultibodyModel
from rrps_sim.dynamics import METHODS, MultibodyDynamics, simulate
from rrps_sim.dynamics.bundles import new_workspace, workspace
from rrps_sim.dynamics.integrators import solve_dependent
from rrps_sim.dynamics.kernels import accelerations, multipliers
from rrps_testing.ci import require

POSITION_OFFSET = np.array([0.01, -0.015, 0.02])
ROTATION = np.array([0.04, -0.03, 0.06])
PUSH = np.array([8.0, -5.0, 2.5, 6.0, -4.0, 1.5])


def compute() -> dict[str, np.ndarray]:
    """The multibody model's and the dynamics' numbers at one off-home pose, in this process."""
    geom = load_robot('pole_climber')
    position = geom.home_position + POSITION_OFFSET
    quat = rotation_vector_to_quat_xyzw(ROTATION)
    out = {}
    model = MultibodyModel(geom)
    q = model.coordinates_from_pose(position, quat)
    lengths = inverse_kinematics(geom, position, quat).lengths
    bent = q + 1e-3 * np.sin(np.arange(91))
    out['constraints'] = model.constraints(bent, lengths)
    out['jacobian'] = model.jacobian(bent)
    dk = model.direct_kinematics(lengths + 0.004, q)
    out['dk_q'] = dk.q
    out['dk_counts'] = np.array([dk.iterations, dk.flops, dk.converged])
    dyn = MultibodyDynamics(geom)
    forces = dyn.holding_forces(position, quat) + PUSH
    out['holding'] = forces - PUSH
    v = np.zeros(78)
    v[:6] = [0.05, -0.02, 0.04, 0.3, -0.2, 0.1]
    assert solve_dependent(q, v, dyn.parameters, 1e-13, 20) >= 0
    acc, lam = np.empty(78), np.empty(72)
    ws = workspace(new_workspace())
    assert accelerations(q, v, forces, 10.0, 10.0, dyn.parameters, ws, acc)
    assert multipliers(dyn.parameters, ws, acc, lam)
    out['accelerations'], out['multipliers'] = acc, lam
    for method in METHODS:
        dyn = MultibodyDynamics(geom, method)
        dyn.reset(position, quat)
        for _ in range(3):
            dyn.step(forces, 0.002)
        out[f'{method}_state'] = np.concatenate([dyn.q, dyn.v, [dyn.actuator_work]])
        out[f'{method}_observed'] = np.concatenate([dyn.position, dyn.lengths, dyn.length_rates,
                                                    [dyn.kinetic_energy, dyn.potential_energy]])
        out[f'{method}_flops'] = np.array([dyn.last_step_flops])
    hybrid = MultibodyDynamics(geom, 'hybrid', correction_tolerance=1e-12)
    hybrid.reset(position, quat)
    opened = hybrid.q.copy()
    opened[21:24] += 1e-5
    hybrid.set_state(opened, hybrid.v)
    hybrid.step(forces, 0.002)
    out['corrected'] = np.concatenate([hybrid.q, hybrid.v, [hybrid.corrections]])
    run = simulate(geom, position, quat, forces, duration=0.004, dt=0.002)
    out['simulated'] = np.concatenate([run.position.ravel(), run.constraint_drift,
                                       run.energy_balance, run.step_flops])
    return out


def test_the_pure_python_kernels_give_the_compiled_numbers(tmp_path):
    require(numba_enabled(), 'numba not available')
    saved = tmp_path / 'python.npz'
    code = ('import sys, numpy as np; from test_backend import compute; '
            'np.savez(sys.argv[1], **compute()); '
            'assert "numba" not in sys.modules, "numba was imported"')
    env = dict(os.environ, RRPS_NUMBA='0')
    done = subprocess.run([sys.executable, '-c', code, str(saved)], cwd=Path(__file__).parent,
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    python = np.load(saved)
    compiled = compute()
    assert sorted(python.files) == sorted(compiled)
    for name, value in compiled.items():
        scale = max(1.0, float(np.max(np.abs(value))))
        np.testing.assert_allclose(python[name], value, rtol=0.0, atol=1e-11 * scale,
                                   err_msg=name)


def test_rrps_numba_0_disables_the_compiled_backend():
    code = ('from rrps_kinematics.backend import numba_enabled, jit\n'
            'def f(x):\n    return x + 1\n'
            'assert not numba_enabled() and jit(f) is f and jit(fastmath=True)(f) is f\n')
    done = subprocess.run([sys.executable, '-c', code], env=dict(os.environ, RRPS_NUMBA='0'),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


def test_numbas_own_disable_jit_runs_the_kernels_interpreted():
    """``NUMBA_DISABLE_JIT=1`` (numba's debugging switch) turns the compiled backend off: the
    modules import and the kernels run as plain Python (numba's njit would return plain functions,
    which have no cache to stamp). The IK's leg lengths are checked against eq. 1 by hand."""
    code = ('import numpy as np\n'
            'from rrps_kinematics.backend import numba_enabled\n'
            'from rrps_description.geometry import load_robot\n'
            'from rrps_kinematics import inverse_kinematics\n'
            'import rrps_kinematics.compiled, rrps_sim.dynamics.kernels, rrps_teleop.compiled_guards\n'
            'g = load_robot("pole_climber")\n'
            'p = np.asarray(g.home_position) + [0.0, 0.0, 0.01]\n'
            'lengths = inverse_kinematics(g, p, g.home_quaternion_xyzw).lengths\n'
            'by_hand = np.linalg.norm(p + np.asarray(g.ring_b_anchors) - np.asarray(g.ring_a_anchors), axis=1)\n'
            'assert not numba_enabled() and np.allclose(lengths, by_hand, atol=1e-12), (lengths, by_hand)\n')
    done = subprocess.run([sys.executable, '-c', code], env=dict(os.environ, NUMBA_DISABLE_JIT='1'),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize('flag', ['1', None])
def test_numba_is_used_unless_disabled(flag):
    require(numba_enabled(), 'numba not available')
    env = {k: v for k, v in os.environ.items() if k != 'RRPS_NUMBA'}
    if flag is not None:
        env['RRPS_NUMBA'] = flag
    code = ('from rrps_kinematics.multibody import leg_residual\n'
            'assert type(leg_residual).__name__ == "CPUDispatcher", type(leg_residual)\n')
    done = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
