"""The teleop load guards (rrps_teleop.load_guard): a motion towards an actuator's force limit or
a holding margin of zero slows down and halts, a motion away moves at full speed, both with the
statics compiled and interpreted; and the load margins are those of the statics, whose forces
are checked by virtual work."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import GripperCapacity, Payload
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_description.world import Support
from rrps_interfaces.teleop import TeleopCode
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.backend import use_numba
from rrps_loads.loads import static_solution
from rrps_teleop.load_guard import LoadGuard
from rrps_teleop.mapping import TeleopConfig, TeleopMapping
from rrps_testing.ci import require
from rrps_testing.virtual_work import quaternion_matrix, virtual_work_forces

BACKENDS = pytest.mark.parametrize('backend', (['numba'] if use_numba('auto') else []) + ['numpy'])
BASE = load_robot('pole_climber').with_(payload=Payload(ring='ring_b', mass=20.0, com=np.array([0.1, 0.0, 0.05])))
WALL = Support.of('ring_a', rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0])))
DT = 0.01
STEPS = 300


def _force_ratio(geom, support, p, q):
    return np.abs(static_solution(geom, Pose(p, q), support=support).actuator_forces).max()


def _holding(geom, support, p, q):
    return float(static_solution(geom, Pose(p, q), support=support).holding_margin)


def _uphill(value, geom, support):
    """The unit direction of ring_b's position along which ``value`` grows fastest at home."""
    p, q = geom.home_position, geom.home_quaternion_xyzw
    h = 1e-4
    grad = np.array([(value(geom, support, p + h * e, q) - value(geom, support, p - h * e, q)) / (2 * h)
                     for e in np.eye(3)])
    return grad / np.linalg.norm(grad)


def _near_force_limit(margin):
    """The robot with max_force set so that its force margin at home is ``margin``; the
    direction towards larger forces."""
    largest = _force_ratio(BASE, WALL, BASE.home_position, BASE.home_quaternion_xyzw)
    return BASE.with_(max_force=largest / (1.0 - margin)), _uphill(_force_ratio, BASE, WALL)


def _near_holding_limit(margin):
    """The robot with ring_a's clamp force set so that the holding margin at home is ``margin``;
    the direction towards a smaller holding margin."""
    clamp = GripperCapacity(clamp_force=1500.0, friction=0.5, radius=0.1)
    geom = BASE.with_(holding={'ring_a': clamp})
    used = 1.0 - _holding(geom, WALL, geom.home_position, geom.home_quaternion_xyzw)
    geom = geom.with_(holding={'ring_a': GripperCapacity(clamp_force=1500.0 * used / (1.0 - margin),
                                                         friction=0.5, radius=0.1)})
    return geom, -_uphill(_holding, geom, WALL)


def _drive(geom, direction, backend, *, config=TeleopConfig(), start=None, steps=STEPS):
    """A Cartesian teleop session at 100 Hz on the wall: the master moves steadily along
    ``direction`` (0.05 m/s at the slave, the speed limit); returns the outputs and the commands'
    positions."""
    mapping = TeleopMapping(geom, config, backend=backend, support=WALL)
    p0 = geom.home_position if start is None else start
    q0 = geom.home_quaternion_xyzw
    mapping.on_slave_pose(p0, q0)
    pm0 = np.zeros(3)
    outs, positions = [], [p0]
    for k in range(steps):
        t = k * DT
        mapping.on_enable(t, True)
        mapping.on_master_pose(t, pm0 + direction * config.max_linear_speed * t / config.translation_scale,
                               np.array([0.0, 0.0, 0.0, 1.0]))
        out = mapping.step(t)
        outs.append(out)
        if out.has_command:
            positions.append(out.position)
            mapping.on_slave_pose(out.position, out.quaternion_xyzw)
    return outs, np.array(positions)


@BACKENDS
@pytest.mark.parametrize('limit', ['force', 'holding'])
def test_a_motion_towards_the_limit_slows_down_and_halts_short_of_it(limit, backend):
    geom, towards = (_near_force_limit if limit == 'force' else _near_holding_limit)(0.05)
    outs, positions = _drive(geom, towards, backend)
    codes = {o.code for o in outs[1:]}
    slow = TeleopCode.DECELERATE_FOR_FORCE if limit == 'force' else TeleopCode.DECELERATE_FOR_HOLDING
    assert slow in codes
    margins = [o.margins[limit] for o in outs[1:]]
    assert min(margins) >= 0.0                                   # never beyond the limit
    assert margins[-1] < 0.05 * 0.5                              # it did approach it
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    full = 0.05 * DT                                             # the speed limit's step
    assert steps[1] < full * (1 - 1e-6) and steps[-1] < 0.05 * full   # slowed, then (nearly) halted
    assert np.all(np.diff(steps[1:]) <= 1e-12)                        # ever slower
    # Without the load guards the same motion goes through the limit.
    free, _ = _drive(geom, towards, backend, config=TeleopConfig(load_guards=False))
    beyond = static_solution(geom, Pose(free[-1].position, free[-1].quaternion_xyzw), support=WALL)
    value = (1.0 - np.abs(beyond.actuator_forces).max() / geom.max_force if limit == 'force'
             else float(beyond.holding_margin))
    assert value < 0.0


@BACKENDS
@pytest.mark.parametrize('limit', ['force', 'holding'])
def test_beyond_the_limit_a_motion_further_halts_and_a_motion_back_is_free(limit, backend):
    geom, towards = (_near_force_limit if limit == 'force' else _near_holding_limit)(-0.02)
    outs, positions = _drive(geom, towards, backend)
    halt = TeleopCode.HALT_FOR_FORCE if limit == 'force' else TeleopCode.HALT_FOR_HOLDING
    assert outs[-1].code == halt
    assert np.allclose(positions[-1], geom.home_position, atol=1e-6)   # it never moved further in
    outs, positions = _drive(geom, -towards, backend, steps=40)     # 2 cm back
    assert {o.code for o in outs[1:]} <= {TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED}
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    np.testing.assert_allclose(steps[1:], 0.05 * DT, rtol=1e-6)   # at the full speed limit
    assert outs[-1].margins[limit] > outs[1].margins[limit]


def test_the_compiled_and_the_numpy_load_margins_agree_with_the_statics():
    require(use_numba('auto'), 'numba is not in use')
    geom, _ = _near_force_limit(0.05)
    guards = [LoadGuard(geom, WALL, backend=b) for b in ('numba', 'numpy')]
    rng = np.random.default_rng(3)
    for _ in range(10):
        p = geom.home_position + 0.03 * rng.standard_normal(3)
        q = rotation_vector_to_quat_xyzw(0.1 * rng.standard_normal(3))
        sol = static_solution(geom, Pose(p, q), support=WALL)
        gravity = quaternion_matrix(WALL.world_q_support).T @ np.array([0.0, 0.0, -9.81])   # in ring_a
        independent = virtual_work_forces(geom, p, quaternion_matrix(q), gravity)
        np.testing.assert_allclose(sol.actuator_forces, independent, rtol=1e-5, atol=1e-6 * 9.81 * geom.total_mass)
        for guard in guards:
            m = guard.margins_at(p, q)
            np.testing.assert_allclose(m.forces, sol.actuator_forces, rtol=1e-9, atol=1e-9)
            assert m.force == pytest.approx(1.0 - np.abs(sol.actuator_forces).max() / geom.max_force, abs=1e-12)
            assert m.holding == pytest.approx(float(sol.holding_margin), abs=1e-12)


def _drive_joint(geom, direction, backend, steps=STEPS):
    """A joint-mode session: the master's leg lengths follow the slave's IK along ``direction``
    (0.05 m/s at the slave), scaled by 1/4; returns the outputs and the commanded lengths."""
    config = TeleopConfig(mode='joint')
    mapping = TeleopMapping(geom, config, backend=backend, support=WALL)
    mapping.on_slave_pose(geom.home_position, geom.home_quaternion_xyzw)
    outs, lengths = [], []
    for k in range(steps):
        t = k * DT
        p = geom.home_position + direction * config.max_linear_speed * t
        mapping.on_enable(t, True)
        mapping.on_master_lengths(t, inverse_kinematics(geom, p, geom.home_quaternion_xyzw).lengths / 4.0)
        out = mapping.step(t)
        outs.append(out)
        if out.has_command:
            lengths.append(out.lengths)
            mapping.on_slave_pose(out.position, out.quaternion_xyzw)
    return outs, np.array(lengths)


def test_both_backends_guard_alike_in_cartesian_and_joint_mode():
    require(use_numba('auto'), 'numba is not in use')
    geom, towards = _near_holding_limit(0.05)
    runs = {b: _drive(geom, towards, b, steps=120) for b in ('numba', 'numpy')}
    np.testing.assert_allclose(runs['numba'][1], runs['numpy'][1], atol=1e-9)
    assert [o.code for o in runs['numba'][0]] == [o.code for o in runs['numpy'][0]]
    joint = {b: _drive_joint(geom, towards, b, steps=120) for b in ('numba', 'numpy')}
    codes = [o.code for o in joint['numba'][0]]
    assert TeleopCode.DECELERATE_FOR_HOLDING in codes and codes == [o.code for o in joint['numpy'][0]]
    np.testing.assert_allclose(joint['numba'][1], joint['numpy'][1], atol=1e-9)
    assert min(o.margins['holding'] for o in joint['numba'][0][1:]) >= 0.0
