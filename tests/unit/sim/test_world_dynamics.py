"""Dynamics in the world: the 13-body DAE (all three integrators) and the reduced model with
ring_b gripping and the world turned, the tool wrench, inverse dynamics on ring_b, the joint
reactions of a run, and why the robot cannot simply be flipped (the leg spin belongs to the
ring with the universal joints)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from rrps_description.geometry import RobotGeometry, load_robot
from rrps_description.loads import ToolWrench
from rrps_description.robot_parts import LinkInertia
from rrps_description.rotations import (
    quat_conjugate_xyzw,
    quat_multiply_xyzw,
    quat_xyzw_to_matrix,
    quat_xyzw_to_rotation_vector,
    rotation_vector_to_quat_xyzw,
)
from rrps_loads.inverse_dynamics import inverse_dynamics
from rrps_loads.loads import static_solution
from rrps_loads.reduced import PlatformPose, body_velocities, platform_accelerations, simulate_reduced
from rrps_loads.statics import holding_forces
from rrps_loads.support import support_of
from rrps_sim.dynamics import METHODS, MultibodyDynamics, simulate

GEOM = load_robot('pole_climber')
TILT = rotation_vector_to_quat_xyzw(np.array([0.9, -0.4, 0.3]))      # the world turned, ~57°
P0 = GEOM.home_position + np.array([0.01, -0.015, 0.02])
Q0 = rotation_vector_to_quat_xyzw(np.array([0.04, -0.03, 0.06]))
PATTERN = np.array([1.5, -1.0, 0.5, 1.0, -0.5, 0.8])


def _angle(q1, q2):
    turn = quat_multiply_xyzw(quat_conjugate_xyzw(q1), q2)
    return 2 * np.arctan2(np.linalg.norm(turn[..., :3], axis=-1), np.abs(turn[..., 3]))


def _push(geom, support, reach=0.1):
    """Holding forces plus a push that would carry the free ring ``reach`` of the robot's size
    in 0.3 s at its initial acceleration."""
    hold = holding_forces(geom, P0, Q0, support=support, world_q_support=TILT)
    pose = PlatformPose(geom, P0, Q0, support_of(support, TILT))
    acc = platform_accelerations(pose, np.zeros((1, 6)), (hold + PATTERN)[None])[0, :3]
    return hold + PATTERN * (reach * geom.characteristic_length / (0.5 * 0.3**2 * np.linalg.norm(acc)))


@functools.lru_cache(maxsize=None)
def _reduced(support):
    f = _push(GEOM, support)
    return f, simulate_reduced(GEOM, P0, Q0, f, 0.3, 0.001, support=support, world_q_support=TILT)


@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('support', ['ring_a', 'ring_b'])
def test_the_dae_on_either_ring_follows_the_reduced_model(support, method):
    f, reduced = _reduced(support)
    dae = simulate(GEOM, P0, Q0, f, duration=0.3, dt=0.001, method=method, support=support,
                   world_q_support=TILT)
    assert np.abs(reduced.position[-1] - P0).max() > 0.01          # a visible relative motion
    assert np.abs(dae.position - reduced.position).max() <= 1e-6
    assert _angle(dae.quaternion_xyzw, reduced.quaternion_xyzw).max() <= 1e-6
    np.testing.assert_allclose(dae.lengths, reduced.lengths, atol=1e-6)
    np.testing.assert_allclose(dae.kinetic, reduced.kinetic_energy, atol=1e-6 * reduced.kinetic_energy.max())
    np.testing.assert_allclose(dae.potential - dae.potential[0],
                               reduced.potential_energy - reduced.potential_energy[0], atol=1e-8)
    assert np.abs(dae.energy_balance).max() <= 1e-8 * dae.kinetic.max()
    assert np.max(dae.constraint_drift) < 1e-10


def test_which_ring_grips_changes_the_motion():
    _, on_a = _reduced('ring_a')
    f_b, on_b = _reduced('ring_b')
    assert np.abs(on_a.position[-1] - on_b.position[-1]).max() > 1e-3
    # the same forces on the other ring do not hold it
    wrong = simulate_reduced(GEOM, P0, Q0, holding_forces(GEOM, P0, Q0, world_q_support=TILT), 0.1, 0.01,
                             support='ring_b', world_q_support=TILT)
    assert np.abs(wrong.position[-1] - P0).max() > 1e-3


def _positions_in_b(geom, p, q):
    """Com positions of ring_a and the 12 links in ring_b's frame, from the description."""
    R = quat_xyzw_to_matrix(q)
    A = (geom.ring_a_anchors - p) @ R
    B = geom.ring_b_anchors
    u = (B - A) / np.linalg.norm(B - A, axis=1)[:, None]
    return ((geom.ring_a_body.com - p) @ R, A + geom.lower_link.com_from_joint * u,
            B - geom.upper_link.com_from_joint * u)


def test_body_velocities_on_ring_b_are_the_rates_of_the_positions_in_ring_bs_frame():
    t0, h = 0.3, 1e-6

    def path(t):
        p = P0 + np.array([0.03 * np.sin(2 * t), -0.02 * t, 0.04 * np.cos(3 * t)])
        return p, rotation_vector_to_quat_xyzw(np.array([0.1 * np.sin(t), 0.05 * t, -0.07 * np.cos(t)]))

    (p1, q1), (p0, q0), (p, q) = path(t0 + h), path(t0 - h), path(t0)
    twist = np.concatenate([(p1 - p0) / (2 * h),
                            quat_xyzw_to_rotation_vector(quat_multiply_xyzw(q1, quat_conjugate_xyzw(q0))) / (2 * h)])
    V = body_velocities(PlatformPose(GEOM, p, q, support_of('ring_b')), twist[None])
    R = quat_xyzw_to_matrix(q)
    rates = [(a - b) / (2 * h) for a, b in zip(_positions_in_b(GEOM, p1, q1), _positions_in_b(GEOM, p0, q0))]
    # the motion model's vectors are in ring_a's frame: turned into ring_b's, they are the rates
    np.testing.assert_allclose(V.ring[0] @ R, rates[0], atol=1e-7)
    np.testing.assert_allclose(V.lower[0] @ R, rates[1], atol=1e-7)
    np.testing.assert_allclose(V.upper[0] @ R, rates[2], atol=1e-7)
    np.testing.assert_allclose(V.ring_angular[0], -twist[3:], atol=1e-12)


def _flipped(geom: RobotGeometry) -> RobotGeometry:
    """The robot turned over: ring_b's anchors on the base, its links swapped: the universal
    joints land on ring_b (the joint types swap)."""
    return RobotGeometry(ring_a_anchors=geom.ring_b_anchors, ring_b_anchors=geom.ring_a_anchors,
                         ring_a_inertia=geom.ring_b_body, ring_b_inertia=geom.ring_a_body,
                         lower_link=geom.upper_link, upper_link=geom.lower_link,
                         home_position=np.array([0.0, 0.0, -geom.home_position[2]]))


def _spinning(geom, axial):
    def link(lk):
        return LinkInertia(mass=lk.mass, com_from_joint=lk.com_from_joint,
                           inertia_transverse=lk.inertia_transverse, inertia_axial=axial * lk.inertia_transverse)
    return geom.with_(lower_link=link(geom.lower_link), upper_link=link(geom.upper_link))


@pytest.mark.parametrize('axial, agrees', [(1e-9, True), (2.0, False)])
def test_flipping_the_robot_is_exact_only_without_the_links_spin_inertia(axial, agrees):
    """ring_b gripping is the flipped robot on ring_a only if the leg spin does not matter: the
    spin follows the ring with the universal joints, which flipping moves to the ground."""
    geom = _spinning(GEOM, axial)
    f = _push(geom, 'ring_b', reach=0.1)
    exact = simulate_reduced(geom, P0, Q0, f, 0.3, 0.01, support='ring_b', world_q_support=TILT)
    R = quat_xyzw_to_matrix(Q0)
    flipped = simulate_reduced(_flipped(geom), -R.T @ P0, quat_conjugate_xyzw(Q0), f, 0.3, 0.01,
                               world_q_support=TILT)
    b_T_a = -np.einsum('kji,kj->ki', quat_xyzw_to_matrix(exact.quaternion_xyzw), exact.position)
    error = np.abs(flipped.position - b_T_a).max()
    assert (error <= 1e-8) == agrees, f'flipped model off by {error:.3g} m'
    assert np.abs(exact.position[-1] - P0).max() > 0.01


def test_the_tool_wrench_acts_alike_in_the_dae_and_the_reduced_model():
    for frame in ('tool', 'world'):
        geom = GEOM.with_(tool_wrench=ToolWrench(force=np.array([4.0, -6.0, 30.0]), torque=np.array([0.8, -0.5, 1.2]),
                                                 frame=frame))
        hold = holding_forces(geom, P0, Q0, world_q_support=TILT)
        assert np.abs(hold - holding_forces(GEOM, P0, Q0, world_q_support=TILT)).max() > 5.0
        np.testing.assert_allclose(MultibodyDynamics(geom, world_q_support=TILT).holding_forces(P0, Q0), hold,
                                   atol=1e-6)
        f = hold + 20.0 * PATTERN
        reduced = simulate_reduced(geom, P0, Q0, f, 0.2, 0.001, world_q_support=TILT)
        dae = simulate(geom, P0, Q0, f, duration=0.2, dt=0.001, world_q_support=TILT)
        assert np.abs(dae.position - reduced.position).max() <= 1e-6, frame


def test_inverse_dynamics_on_ring_b_drives_the_dae_along_the_trajectory():
    t = 0.001 * np.arange(401)
    s = 0.5 * (1.0 - np.cos(np.pi * t / 0.4))
    p = P0 + s[:, None] * np.array([0.02, -0.01, 0.03])
    q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(s[:, None] * np.array([0.05, -0.03, 0.08])), Q0)
    F = inverse_dynamics(GEOM, t, p, q, support='ring_b', world_q_support=TILT)
    assert np.abs(F - F[0]).max() > 1.0
    run = simulate(GEOM, p[0], q[0], lambda time, dyn: [np.interp(time + 0.0005, t, F[:, i]) for i in range(6)],
                   duration=0.4, dt=0.001, support='ring_b', world_q_support=TILT)
    assert np.abs(run.position - p).max() <= 1e-6
    assert _angle(run.quaternion_xyzw, q).max() <= 2e-6          # 0.5 µm at the rings' radius


def test_reactions_of_a_run_at_rest_are_the_statics_and_compiled_runs_record_them_as_steps_do():
    sol = static_solution(GEOM, (P0, Q0), support='ring_b', world_q_support=TILT)
    run = simulate(GEOM, P0, Q0, sol.actuator_forces, duration=0.02, dt=0.002, support='ring_b',
                   world_q_support=TILT, reactions=True, output_every=5)
    assert run.universal_reactions.shape == (3, 6, 3) and run.support_wrench.shape == (3, 6)
    np.testing.assert_allclose(run.universal_reactions, np.broadcast_to(sol.universal_reactions, (3, 6, 3)), atol=1e-6)
    np.testing.assert_allclose(run.spherical_reactions, np.broadcast_to(sol.spherical_reactions, (3, 6, 3)), atol=1e-6)
    np.testing.assert_allclose(run.support_wrench, np.broadcast_to(sol.support_wrench, (3, 6)), atol=1e-6)
    f = sol.actuator_forces + 15.0 * PATTERN
    batch = simulate(GEOM, P0, Q0, f, duration=0.03, dt=0.001, output_every=4, reactions=True)
    steps = simulate(GEOM, P0, Q0, lambda time, dyn: f, duration=0.03, dt=0.001, output_every=4, reactions=True)
    for name in ('universal_reactions', 'spherical_reactions', 'support_wrench'):
        np.testing.assert_array_equal(getattr(batch, name), getattr(steps, name), err_msg=name)
    assert np.abs(batch.universal_reactions[-1] - batch.universal_reactions[0]).max() > 1.0
    assert simulate(GEOM, P0, Q0, f, duration=0.01, dt=0.001).support_wrench is None


def test_a_gripper_change_regrounds_the_dae_at_rest():
    dyn = MultibodyDynamics(GEOM, 'hybrid', world_q_support=TILT)
    dyn.reset(P0, Q0)
    dyn.step(holding_forces(GEOM, P0, Q0, world_q_support=TILT), 0.001)
    world_q_b = quat_multiply_xyzw(TILT, Q0)            # ring_b's attitude: world_T_a @ a_T_b
    dyn.set_support('ring_b', world_q_b)
    np.testing.assert_allclose(dyn.position, P0, atol=1e-12)
    assert dyn.time == pytest.approx(0.001)
    hold_b = holding_forces(GEOM, P0, Q0, support='ring_b', world_q_support=world_q_b)
    for _ in range(50):
        dyn.step(hold_b, 0.001)
    np.testing.assert_allclose(dyn.position, P0, atol=1e-10)
    # on ring_b in the same world ring_a weighs on the legs, so the forces differ
    assert np.abs(hold_b - holding_forces(GEOM, P0, Q0, world_q_support=TILT)).max() > 10.0
