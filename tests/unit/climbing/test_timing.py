"""The timing of a motion (climbing.timing, TOPP-RA made jerk-limited) against computations written
here: the fastest rest-to-rest motion the legs' speed and acceleration allow along the same path
(phase-plane integration), each leg's speed, acceleration and jerk by finite differences of its
IK length along the timed samples, and the hand-over's minimum-norm split by a least-squares
solve of its own."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.handover import handover_loads
from rrps_climbing.timing import SAMPLE_PERIOD, time_motion
from rrps_description.geometry import load_robot
from rrps_description.motion_limits import STREAM_RATE_SHARE, STREAM_SPEED_SHARE
from rrps_description.pose import Pose
from rrps_description.structures import make_structure
from rrps_kinematics import inverse_kinematics
from rrps_loads.loads import static_solution

POLE = load_robot('pole_climber')


def _straight(distance=0.15, n=16):
    """ring_b rising straight up from home, n samples."""
    path = np.tile(np.eye(4), (n, 1, 1))
    path[:, :3, 3] = POLE.home_position + np.linspace(0.0, distance, n)[:, None] * [0.0, 0.0, 1.0]
    return path, np.zeros((n, 2))


def _bound(geometry, path, speed_share, rate_share):
    """Phase-plane integration (forward at the largest acceleration, backward at the largest
    deceleration) with L'(s), L''(s) by central differences of IK lengths along the straight line."""
    legs = geometry.motion_limits.legs
    v_max, a_max = speed_share * legs.speed, rate_share * legs.acceleration
    p0, p1 = path[0, :3, 3], path[-1, :3, 3]
    length = np.linalg.norm(p1 - p0)
    s = np.linspace(0.0, length, 3001)
    h = 1e-5

    def lengths(x):
        identity = np.tile([0, 0, 0, 1.0], (len(x), 1))
        return inverse_kinematics(geometry, p0 + np.outer(x / length, p1 - p0), identity).lengths
    L1 = (lengths(s + h) - lengths(s - h)) / (2 * h)
    L2 = (lengths(s + h) - 2 * lengths(s) + lengths(s - h)) / h ** 2
    x_max = np.min((v_max / np.abs(L1)) ** 2, axis=1)

    def u(k, x, sign):
        ends = np.sort(np.stack([(-a_max - L2[k] * x) / L1[k], (a_max - L2[k] * x) / L1[k]]), axis=0)
        return ends[1].min() if sign > 0 else ends[0].max()
    x = np.zeros(len(s))
    for k in range(len(s) - 1):
        x[k + 1] = min(x_max[k + 1], x[k] + 2 * (s[k + 1] - s[k]) * u(k, x[k], +1))
    x[-1] = 0.0
    for k in range(len(s) - 2, -1, -1):
        x[k] = min(x[k], x[k + 1] - 2 * (s[k + 1] - s[k]) * u(k + 1, x[k + 1], -1))
    v = np.sqrt(np.maximum(x, 0.0))
    return float(np.sum(2 * np.diff(s) / np.maximum(v[:-1] + v[1:], 1e-12)))


def test_a_straight_motion_takes_the_time_optimal_bound_within_2_percent_plus_its_jerk_window():
    path, angles = _straight()
    timed = time_motion(POLE, path, angles)
    (curve, law), = timed.pieces
    bound = _bound(POLE, path, STREAM_SPEED_SHARE, STREAM_RATE_SHARE)
    # TOPP-RA's bang-bang law reaches the bound of the same limits; the jerk-limited law adds its window
    assert bound * 0.999 <= law.law.duration <= 1.02 * bound
    assert law.duration == pytest.approx((law.law.duration + law.window) * law.scale)
    assert timed.duration <= 1.02 * bound + 1.01 * law.window
    assert law.window == pytest.approx(POLE.motion_limits.legs.acceleration / POLE.motion_limits.legs.jerk, rel=0.1)
    # ... and the full limits' bound, which any motion takes at least
    assert timed.duration >= _bound(POLE, path, 1.0, 1.0)


@pytest.mark.parametrize('robot,structure', [('pole_climber', 'palm_trunk'), ('facade_climber', 'facade'),
                                             ('frame_climber', 'frame')])
def test_every_timed_sample_is_within_the_legs_speed_acceleration_and_jerk(robot, structure):
    g = load_robot(robot)
    plan = GaitPlanner(g, make_structure(structure, 2.0)).plan(0.4)
    legs = g.motion_limits.legs
    dt = SAMPLE_PERIOD
    for ph in plan.phases:
        if ph.timing is None:
            continue
        p, q, _ = ph.timing.poses(np.arange(-3, round(ph.timing.duration / dt) + 4) * dt)
        L = inverse_kinematics(g, p, q).lengths
        v = np.diff(L, axis=0) / dt
        a = np.diff(v, axis=0) / dt
        j = np.diff(a, axis=0) / dt
        assert np.abs(v).max() <= legs.speed and np.abs(a).max() <= legs.acceleration * 1.001
        assert np.abs(j).max() <= legs.jerk * 1.01, (ph.step, ph.phase)
        # it starts and stops at rest, without a jump
        assert np.abs(v[:3]).max() < 1e-6 and np.abs(v[-3:]).max() < 1e-6


def test_a_speed_cap_bounds_the_path_speed():
    path, angles = _straight()
    capped = time_motion(POLE, path, angles, speed=0.01)
    free = time_motion(POLE, path, angles)
    assert capped.peak_speed <= 0.01 * (1 + 1e-9) and not capped.capped
    assert capped.duration >= 0.15 / 0.01 and free.duration < capped.duration
    fast = time_motion(POLE, path, angles, speed=5.0)
    assert fast.capped and fast.duration == pytest.approx(free.duration)


def test_a_hand_over_splits_the_load_by_minimum_norm_and_balances_the_robot():
    g = POLE
    a_T_b = Pose(g.home_position + [0.01, 0.0, 0.02], [0.0, 0.0, 0.0, 1.0])
    lean = (np.sin(np.radians(15)), 0.0, 0.0, np.cos(np.radians(15)))
    split = handover_loads(g, a_T_b, lean, (0.0, 0.0, -9.81))
    alone = static_solution(g, a_T_b, support='ring_a', world_q_support=lean)
    # written here: all splits (w_a, w_b) with w_a + X w_b = w_a0, X the wrench transform from
    # ring_b's origin and frame to ring_a's; the one of least weighted norm by least squares
    R, p = a_T_b.rotation, a_T_b.position
    skew = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    X = np.block([[R, np.zeros((3, 3))], [skew @ R, R]])
    c = g.characteristic_length
    S = np.diag([1.0, 1.0, 1.0, 1 / c, 1 / c, 1 / c])
    # minimise |S (w_a0 - X w_b)|^2 + |S w_b|^2 over w_b: one stacked least-squares problem
    A = np.vstack([S @ X, S])
    b = np.concatenate([S @ alone.support_wrench, np.zeros(6)])
    w_b = np.linalg.lstsq(A, b, rcond=None)[0]
    np.testing.assert_allclose(split.wrench_b, w_b, atol=1e-9)
    np.testing.assert_allclose(split.wrench_a + X @ split.wrench_b, alone.support_wrench, atol=1e-9)
    # the legs carry what ring_b's grip does not: J^T (f - f_a) = -(R f_b, R m_b), J by differences
    h = 1e-7
    J = np.zeros((6, 6))
    for i in range(6):
        twist = np.zeros(6)
        twist[i] = h
        dq = np.concatenate([0.5 * twist[3:], [1.0]])
        moved = inverse_kinematics(g, p + twist[:3], dq / np.linalg.norm(dq)).lengths
        J[:, i] = (moved - inverse_kinematics(g, p, [0, 0, 0, 1.0]).lengths) / h
    np.testing.assert_allclose(J.T @ (split.forces - alone.actuator_forces),
                               -np.concatenate([R @ split.wrench_b[:3], R @ split.wrench_b[3:]]), atol=1e-3)
    assert 0.0 < split.margin_a < 1.0 and 0.0 < split.margin_b < 1.0
