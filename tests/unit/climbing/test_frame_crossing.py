"""The frame-node manoeuvre: every pose of every junction's plan against every limit, recomputed
here from eq. 1 (leg vectors from the anchors), its loads against virtual work and the robot's
balance, and the refusal without the extra ring DOF."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.plan import PlanError, PlanLimit
from rrps_description.geometry import load_robot
from rrps_kinematics.odometry import invert

JUNCTIONS = [(deg, out) for deg in (30, 45, 60, 90) for out in (False, True)]
pytestmark = pytest.mark.slow  # eight searches of a few seconds each, shared by the module


@pytest.fixture(scope='module')
def plans():
    g = load_robot('frame_climber')
    out = {}
    for deg, out_of_plane in JUNCTIONS:
        planner = FrameNodePlanner(g, deg, out_of_plane)
        out[deg, out_of_plane] = (planner, planner.plan_crossing())
    return out


def _world_paths(phase):
    """(world_T_a, world_T_b) of every sample of a phase: the gripping ring stays where the
    odometry put it at the phase's end."""
    if phase.gripper_a:
        wa = np.broadcast_to(phase.world_T_a.matrix, phase.path.shape)
        return wa, wa @ phase.path
    wb = np.broadcast_to(phase.world_T_b.matrix, phase.path.shape)
    return wb @ invert(phase.path), wb


def _segment_distance(p0, p1, q0, q1, n=401):
    """Smallest distance between segments p0-p1 and q0-q1 (batch over leading axes): every
    point of a fine sampling of the first, projected (clamped) onto the second."""
    s = np.linspace(0.0, 1.0, n)
    P = p0[..., None, :] + s[:, None] * (p1 - p0)[..., None, :]
    d = (q1 - q0)[..., None, :]
    t = np.clip(np.sum((P - q0[..., None, :]) * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
    return np.min(np.linalg.norm(P - q0[..., None, :] - t[..., None] * d, axis=-1), axis=-1)


def _limits(g, frame, wa, wb):
    """Every limit at the poses (n, 4, 4) of both rings in the world, from eq. 1."""
    a_T_b = invert(wa) @ wb
    R, p = a_T_b[:, :3, :3], a_T_b[:, :3, 3]
    Rb = np.einsum('nij,kj->nki', R, g.ring_b_anchors)                 # R b_i in ring_a
    legs = p[:, None, :] + Rb - g.ring_a_anchors                         # eq. 1: L_i
    length = np.linalg.norm(legs, axis=-1)
    u = legs / length[..., None]
    universal = np.arccos(np.clip(np.einsum('nki,ki->nk', u, g.ring_a_joint_axes), -1, 1))
    u_b = np.einsum('nji,nkj->nki', R, -u)                               # leg seen from ring_b
    spherical = np.arccos(np.clip(np.einsum('nki,ki->nk', u_b, g.ring_b_joint_axes), -1, 1))
    J = np.concatenate([u, np.cross(Rb, u) / g.characteristic_length], axis=-1)
    sv = np.linalg.svd(J, compute_uv=False)
    A = g.ring_a_anchors[None].repeat(len(p), 0)
    B = g.ring_a_anchors + legs
    pair = np.full(len(p), np.inf)
    for i in range(6):
        for j in range(i + 1, 6):
            pair = np.minimum(pair, _segment_distance(A[:, i], B[:, i], A[:, j], B[:, j]))
    # legs to every beam at the node, in the world: capsule of the square section's circumradius
    Aw = np.einsum('nij,kj->nki', wa[:, :3, :3], g.ring_a_anchors) + wa[:, None, :3, 3]
    Bw = np.einsum('nij,kj->nki', wb[:, :3, :3], g.ring_b_anchors) + wb[:, None, :3, 3]
    node = frame.nodes['J']
    beam = post = np.inf
    for a, b in frame.beams:
        q0, q1 = frame.nodes[a], frame.nodes[b]
        if np.linalg.norm(q0 - node) > 1e-9:  # beams framing into the node: from the node out
            q0, q1 = q1, q0
        q1 = q0 + (q1 - q0) * min(1.0, 1.5 / np.linalg.norm(q1 - q0))  # the node's neighbourhood
        for k in range(6):
            d = _segment_distance(Aw[:, k], Bw[:, k], np.broadcast_to(q0, (len(p), 3)),
                                  np.broadcast_to(q1, (len(p), 3)))
            beam = np.minimum(beam, d)
        if {a, b} in ({'base', 'J'}, {'J', 'top'}):
            continue  # the climbed beams: ring_b's post stands over them a ring height off
        # ring_b's gripper post: from ring_b down its stand-off (to ring_a's height over the face)
        top = wb[:, :3, 3]
        foot = top - g.home_position[2] * wb[:, :3, 2]
        post = np.minimum(post, _segment_distance(top, foot, np.broadcast_to(q0, (len(p), 3)),
                                                  np.broadcast_to(q1, (len(p), 3))))
    return {'length': length, 'universal': universal, 'spherical': spherical,
            'inverse_condition': sv[:, -1] / sv[:, 0], 'leg_leg': pair, 'leg_beam': beam, 'post_beam': post}


@pytest.mark.parametrize('deg, out_of_plane', JUNCTIONS)
def test_every_pose_keeps_every_limit_recomputed_from_eq_1(plans, deg, out_of_plane):
    planner, plan = plans[deg, out_of_plane]
    g, frame = planner.geometry, planner.frame
    moves = [ph for ph in plan.phases if ph.phase.startswith('move')]
    assert [ph.phase for ph in moves] == ['move_b', 'move_a']
    for ph in plan.phases:
        wa, wb = _world_paths(ph)
        lim = _limits(g, frame, wa, wb)
        where = f'{deg} deg, {ph.phase}'
        assert np.all(lim['length'] >= g.min_length - 1e-9) and np.all(lim['length'] <= g.max_length + 1e-9), where
        assert np.all(lim['universal'] <= g.universal_max_angle + 1e-9), where
        assert np.all(lim['spherical'] <= g.spherical_max_angle + 1e-9), where
        assert np.all(lim['leg_leg'] >= 2.0 * g.leg_radius - 1e-6), where
        assert np.all(lim['inverse_condition'] >= g.min_conditioning), where
        assert np.all(lim['leg_beam'] >= g.leg_radius + math.sqrt(2.0) * frame.half_width - 1e-9), where
        assert np.all(lim['post_beam'] >= g.leg_radius + math.sqrt(2.0) * frame.half_width - 1e-9), where


def _rotate(R, v):
    """exp([v]x) R (Rodrigues), v a rotation vector in the world."""
    angle = np.linalg.norm(v)
    if angle < 1e-15:
        return R
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return (np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K) @ R


def _bodies(g, wa, wb):
    """(masses (7+12,), centres of mass (19, 3)) of both rings and every leg's two links, world."""
    A = wa[:3, :3] @ g.ring_a_anchors.T + wa[:3, 3:4]
    B = wb[:3, :3] @ g.ring_b_anchors.T + wb[:3, 3:4]
    u = (B - A) / np.linalg.norm(B - A, axis=0)
    com = np.vstack([wa[:3, :3] @ g.ring_a_body.com + wa[:3, 3], wb[:3, :3] @ g.ring_b_body.com + wb[:3, 3],
                     (A + g.lower_link.com_from_joint * u).T, (B - g.upper_link.com_from_joint * u).T])
    mass = np.r_[g.ring_a_body.mass, g.ring_b_body.mass, [g.lower_link.mass] * 6, [g.upper_link.mass] * 6]
    return mass, com


def _virtual_work_forces(g, wa, wb, moving, gravity, h=1e-6):
    """Actuator forces at rest from virtual work: sum F_i dl_i = dV for every small motion of the
    moving ring (finite differences of the leg lengths of eq. 1 and of the potential energy)."""
    def state(d):
        T = (wa if moving == 'a' else wb).copy()
        T[:3, :3], T[:3, 3] = _rotate(T[:3, :3], d[3:]), T[:3, 3] + d[:3]
        a, b = (T, wb) if moving == 'a' else (wa, T)
        legs = (b[:3, :3] @ g.ring_b_anchors.T + b[:3, 3:4]) - (a[:3, :3] @ g.ring_a_anchors.T + a[:3, 3:4])
        mass, com = _bodies(g, a, b)
        return np.linalg.norm(legs, axis=0), -np.sum(mass * (com @ gravity))
    dl, dV = np.zeros((6, 6)), np.zeros(6)
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        (lp, vp), (lm, vm) = state(e), state(-e)
        dl[:, j], dV[j] = (lp - lm) / (2 * h), (vp - vm) / (2 * h)
    return np.linalg.solve(dl.T, dV)


@pytest.mark.parametrize('deg, out_of_plane', JUNCTIONS)
def test_forces_and_holding_against_virtual_work_and_the_robots_balance(plans, deg, out_of_plane):
    """The planner's peak actuator force and smallest holding margin of each motion (from
    rrps_loads' statics) against virtual work and the whole robot's balance, computed here."""
    planner, plan = plans[deg, out_of_plane]
    g, gravity = planner.geometry, np.array([0.0, 0.0, -9.81])
    for ph in (p for p in plan.phases if p.phase.startswith('move')):
        moving = ph.phase[-1]
        wa_all, wb_all = _world_paths(ph)
        peak, holding = 0.0, np.inf
        for wa, wb in zip(wa_all, wb_all):
            peak = max(peak, np.max(np.abs(_virtual_work_forces(g, wa, wb, moving, gravity))))
            # the gripping ring's clamp holds the whole robot: force and moment at the clamped
            # section (the beam's centreline under its gripper), along the beam / the face normal
            T = wb if moving == 'a' else wa
            grip = T[:3, 3] - (g.home_position[2] * T[:3, 2] if moving == 'a' else 0.0)
            axis = T[:3, :3] @ np.array([math.cos(ph.ring_angles[0][0 if moving == 'b' else 1]),
                                         math.sin(ph.ring_angles[0][0 if moving == 'b' else 1]), 0.0])
            section = grip - (planner.frame.half_width + 0.1) * T[:3, 2]
            mass, com = _bodies(g, wa, wb)
            force = -np.sum(mass) * gravity
            moment = -np.sum(np.cross(com - section, mass[:, None] * gravity), axis=0)
            cap = g.holding['ring_a' if moving == 'b' else 'ring_b']
            demand = math.hypot(force @ axis, (moment @ T[:3, 2]) / cap.radius)
            holding = min(holding, 1.0 - demand / (cap.friction * cap.clamp_force))
        found = planner.crossing
        assert found.peak_force[ph.phase][0] == pytest.approx(peak, rel=1e-4), ph.phase
        assert found.margins[ph.phase]['holding'] == pytest.approx(holding, abs=1e-6), ph.phase
        assert peak < g.max_force and holding > 0.0


@pytest.mark.parametrize('deg, out_of_plane', JUNCTIONS)
def test_the_crossing_ends_on_the_second_beam_with_untwisted_rings(plans, deg, out_of_plane):
    planner, plan = plans[deg, out_of_plane]
    lo, hi = planner.structure.forbidden[0]
    first, last = plan.phases[0], plan.phases[-1]
    assert first.s_a <= lo and first.s_b <= lo and last.s_a >= hi and last.s_b >= hi
    for ph in plan.phases:  # the extra DOF cancels the turn about the ring axis: no relative twist
        R = ph.path[:, :3, :3]
        assert np.allclose(R, np.eye(3), atol=1e-6), ph.phase
    assert math.isclose(abs(math.degrees(last.theta_a)), deg, abs_tol=1e-6)
    assert math.isclose(last.theta_a, last.theta_b, abs_tol=1e-9)
    # every gripper past the node grips the second beam's face: its axis normal to both beams
    z2 = planner.frame.nodes['top'] - planner.frame.nodes['J']
    Rb = last.world_T_b.matrix[:3, :3]
    assert abs(Rb[:, 2] @ z2) < 1e-9
    loads = planner.crossing.margins
    assert all(loads[p]['actuator_force'] >= 0.0 and loads[p]['holding'] >= 0.0 for p in loads)


def test_a_90_deg_node_is_refused_without_the_extra_dof_naming_the_limit_and_phase():
    planner = FrameNodePlanner(load_robot('frame_climber'), 90, use_extra_dof=False)
    assert planner.crossing is None
    exc = planner.refusal
    assert exc.phase in ('move_b', 'move_a')
    assert exc.limit in (PlanLimit.STROKE, PlanLimit.UNIVERSAL, PlanLimit.SPHERICAL,
                         PlanLimit.INTERFERENCE, PlanLimit.CONDITIONING)
    assert exc.limit.value in str(exc) and exc.phase in str(exc)
    with pytest.raises(PlanError):
        planner.plan(0.5)


def test_the_batched_search_and_the_plain_grid_search_choose_the_same_crossing(plans):
    planner, _ = plans[60, True]
    plain = FrameNodePlanner(planner.geometry, 60, True, batched=False)
    assert plain.crossing.candidate == planner.crossing.candidate
    assert math.isclose(plain.crossing.score, planner.crossing.score, rel_tol=1e-9)


def test_bad_input_is_a_clear_error():
    g = load_robot('frame_climber')
    for bad in (0.0, 95.0, math.nan):
        with pytest.raises(ValueError, match='junction_deg'):
            FrameNodePlanner(g, bad)
