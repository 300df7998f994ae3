"""Routes (climbing.route): a frame route over two nodes, up and down, and the facade climber
round a corner, each checked against geometry written here: every closed gripper stands on the
structure (on a beam face at the section's height and off the nodes, or on a wall and off its
edge), every pose's leg lengths (from the anchors) are within the stroke, the legs never
cross, the interlock never releases both rings and a closed ring never moves; a route the
limits cannot realise is refused naming the limit, the step and the phase."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_climbing import cli
from rrps_climbing.frame_crossing import LIMITS
from rrps_climbing.plan import PlanError
from rrps_climbing.route import FrameRoutePlanner, frame_route, plan_route
from rrps_description.geometry import load_robot
from rrps_testing.virtual_work import quaternion_matrix

FRAME = load_robot('frame_climber')
FACADE = load_robot('facade_climber')
CLEARANCE = 0.1          # no gripper within this of a node (the frame's gusset plates) [m]
FACE_HEIGHT = 0.06 + 0.1  # the section's half width plus the ring height: the gripper above the beam axis [m]


def _matrix(pose) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = quaternion_matrix(pose.quaternion_xyzw), pose.position
    return T


def _grippers(geometry, ph) -> dict:
    """{ring: (point, axis)} of the closed grippers at the end of a phase: ring_a's at its origin,
    ring_b's a stand-off below it, both along the ring axis."""
    out = {}
    standoff = geometry.home_position[2]
    for ring, closed, pose in (('ring_a', ph.gripper_a, ph.world_T_a), ('ring_b', ph.gripper_b, ph.world_T_b)):
        if closed:
            T = _matrix(pose)
            z = T[:3, 2]
            out[ring] = (T[:3, 3] - (standoff * z if ring == 'ring_b' else 0.0), z)
    return out


def _segment_distance(p0, p1, q0, q1, n: int = 60) -> float:
    """Smallest distance between two segments, sampled finely on both."""
    t = np.linspace(0.0, 1.0, n)
    a = p0 + t[:, None] * (p1 - p0)
    b = q0 + t[:, None] * (q1 - q0)
    return float(np.min(np.linalg.norm(a[:, None] - b[None], axis=-1)))


def _check_poses(geometry, plan):
    """Every sampled pose: leg lengths within the stroke; the six legs (sampled at their phase
    ends) never closer than two leg radii."""
    a, b = geometry.ring_a_anchors, geometry.ring_b_anchors
    for ph in plan.phases:
        tips = ph.path[:, None, :3, 3] + np.einsum('nij,kj->nki', ph.path[:, :3, :3], b)
        lengths = np.linalg.norm(tips - a[None], axis=-1)
        assert np.all(lengths >= geometry.min_length - 1e-9) and np.all(lengths <= geometry.max_length + 1e-9), \
            (ph.step, ph.phase)
        for k in (0, len(ph.path) // 2, len(ph.path) - 1):
            gaps = [_segment_distance(a[i], tips[k, i], a[j], tips[k, j]) for i in range(6) for j in range(i + 1, 6)
                    if i + 1 != j and not (i == 0 and j == 5)]   # neighbours share an anchor region
            assert min(gaps) > 0.0, (ph.step, ph.phase)


def _check_interlock(plan):
    """Never both open; one gripper switches at a time; a ring closed before and after a phase
    stays where it is in the world."""
    for before, ph in zip(plan.phases, plan.phases[1:]):
        assert ph.gripper_a or ph.gripper_b, (ph.step, ph.phase)
        assert (before.gripper_a, before.gripper_b) == (ph.gripper_a, ph.gripper_b) or \
            (before.gripper_a == ph.gripper_a) != (before.gripper_b == ph.gripper_b)
        for closed, p0, p1 in ((before.gripper_a and ph.gripper_a, before.world_T_a, ph.world_T_a),
                               (before.gripper_b and ph.gripper_b, before.world_T_b, ph.world_T_b)):
            if closed:
                np.testing.assert_allclose(_matrix(p1), _matrix(p0), atol=1e-9)


def _on_the_frame(plan, points, normal):
    """Each closed gripper a face height above a beam axis, on the face of ``normal``, off the
    nodes; its axis along the face normal."""
    for ph in plan.phases:
        for ring, (p, z) in _grippers(FRAME, ph).items():
            best = None
            for q0, q1 in zip(points[:-1], points[1:]):
                u = (q1 - q0) / np.linalg.norm(q1 - q0)
                t = float(np.clip((p - q0) @ u, 0.0, np.linalg.norm(q1 - q0)))
                d = p - (q0 + t * u)
                if best is None or np.linalg.norm(d) < np.linalg.norm(best[0]):
                    best = (d, q0 + t * u)
            d, foot = best
            assert np.linalg.norm(d) == pytest.approx(FACE_HEIGHT, abs=1e-6), (ph.step, ph.phase, ring)
            np.testing.assert_allclose(d / np.linalg.norm(d), normal, atol=1e-6)
            np.testing.assert_allclose(z, normal, atol=1e-6)
            assert min(np.linalg.norm(foot - n) for n in points[1:-1]) >= CLEARANCE - 1e-6, (ph.step, ph.phase)


@pytest.fixture(scope='module')
def route():
    frame = frame_route((30.0, 30.0))
    return frame, FrameRoutePlanner(FRAME, frame)


def test_a_frame_route_over_two_nodes_up_and_down(route):
    frame, planner = route
    points = [frame.nodes[n] for n in frame.route]
    # the test's own face normal: the beams' plane (x-z) normal, on the side the route stands
    normal = np.cross(points[1] - points[0], points[2] - points[1])
    normal /= np.linalg.norm(normal)
    up = planner.plan(3.0, start=0.3)
    normal = normal if _grippers(FRAME, up.phases[0])['ring_a'][1] @ normal > 0.0 else -normal
    down = planner.plan(-3.0, start=3.3)
    for plan in (up, down):
        _on_the_frame(plan, points, normal)
        _check_poses(FRAME, plan)
        _check_interlock(plan)
    # up crosses both nodes to 3.3 m; down comes back to where up started
    assert up.phases[-1].s_a == pytest.approx(3.3) and up.phases[-1].s_b == pytest.approx(3.3)
    for ring in ('world_T_a', 'world_T_b'):
        np.testing.assert_allclose(_matrix(getattr(down.phases[-1], ring)), _matrix(getattr(up.phases[0], ring)),
                                   atol=1e-9)
        np.testing.assert_allclose(_matrix(getattr(down.phases[0], ring)), _matrix(getattr(up.phases[-1], ring)),
                                   atol=1e-9)
    # at the top the grippers lie along the last beam (turned 60 deg), the rings as at the foot:
    # the extra DOF took the whole turn
    grip_x = (_matrix(up.phases[-1].world_T_a)[:3, :3] @ np.array(
        [math.cos(up.phases[-1].theta_a), math.sin(up.phases[-1].theta_a), 0.0]))
    last = (points[-1] - points[-2]) / np.linalg.norm(points[-1] - points[-2])
    assert abs(grip_x @ last) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(quaternion_matrix(up.phases[-1].world_T_a.quaternion_xyzw),
                               quaternion_matrix(up.phases[0].world_T_a.quaternion_xyzw), atol=1e-6)
    assert abs(up.phases[-1].theta_a) == pytest.approx(math.radians(60.0), abs=1e-9)
    # the loads the searches and the walking checks found, on every motion
    moves = [ph for ph in up.phases if ph.phase.startswith('move')]
    assert all(ph.loads is not None and 0.0 < ph.loads.peak_force < FRAME.max_force for ph in moves)


def test_the_facade_climber_round_a_corner():
    corner = 20.0
    for distance, start in ((1.0, 1.5), (-1.0, 2.5)):
        _, plan, structure = plan_route(FACADE, 'facade_corner', distance, start=start, corner_deg=corner)
        _check_poses(FACADE, plan)
        _check_interlock(plan)
        c = math.radians(corner)
        walls = [(np.array([2.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0])),
                 (np.array([2.0, 0.0, 1.0]), np.array([math.sin(c), -math.cos(c), 0.0]),
                  np.array([math.cos(c), math.sin(c), 0.0]))]   # edge point, outward normal, along the route
        sides = set()
        for ph in plan.phases:
            for ring, (p, z) in _grippers(FACADE, ph).items():
                along = [(p - e) @ d for e, _, d in walls]
                k = 0 if along[0] <= 0.0 else 1
                e, n, _ = walls[k]
                assert abs((p - e) @ n) < 1e-9, (ph.step, ph.phase, ring)       # on that wall
                np.testing.assert_allclose(z, n, atol=1e-9)                      # standing on it
                assert abs(along[k]) >= 0.06 - 1e-9                              # off the edge
                sides.add(k)
        assert sides == {0, 1}                                                   # round the corner


def test_a_route_the_limits_cannot_realise_is_refused(capsys):
    with pytest.raises(PlanError) as refused:
        FrameRoutePlanner(FRAME, frame_route((90.0,)), use_extra_dof=False)
    e = refused.value
    assert e.limit.value in LIMITS and e.phase == 'move_b' and e.step == 1 and 'node 1' in str(e)
    with pytest.raises(PlanError) as refused:
        plan_route(FACADE, 'facade_corner', 1.0, corner_deg=45.0)
    e = refused.value
    assert e.limit.value == 'stroke' and e.step is not None and e.phase.startswith('move')
    assert cli.main(['--robot', 'facade_climber', '--structure', 'facade_corner', '--distance', '1.0',
                     '--corner-deg', '45']) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'refused' in err[0] and f'step {e.step}, phase {e.phase}' in err[0] and 'stroke' in err[0]
    assert cli.main(['--robot', 'frame_climber', '--structure', 'frame_route', '--distance', '2.0',
                     '--bends', '90', '--no-extra-dof']) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'node 1' in err[0] and 'phase move_b' in err[0]
    assert cli.main(['--robot', 'frame_climber', '--structure', 'frame_route', '--distance', '3.0',
                     '--start', '1.55']) == 2                                    # within a node's zone
    assert 'node zone' in capsys.readouterr().err
