"""The driver's gravity follows the climb's odometry over ROS (the attitude from odometry, not
from parameters): the driver starts upright (its ``world_q_support`` parameter left at the
identity) while the robot climbs a pole leaning 30 deg or the curved palm trunk; once the climb
node's ``odometry/support`` comes, the simulated gravity in the supporting ring's frame is the
world's gravity turned by that ring's attitude where it grips, computed here independently: a
turn about x written out for the pole; for the trunk the structure's grip frame at the route
position of the plan, with the tilt of the ring axis checked against the trunk's centreline
differentiated by hand. Every sample after the first odometry matches one of the attitudes the
rings take on the way (the hand-overs included)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from std_srvs.srv import Trigger

from rrps_climbing.gait import GaitPlanner
from rrps_description.geometry import load_robot
from rrps_description.structures import make_structure
from rrps_interfaces.climb import CLIMB_RESUME, ClimbState, ClimbStatus
from rrps_interfaces.driver import DriverStatus, SupportSource
from rrps_testing.climb_stack import climb_stack
from rrps_testing.node_helpers import statuses
from rrps_testing.ros_harness import Probe, Spinner, wait_for
from rrps_testing.virtual_work import rotation_x

pytestmark = [pytest.mark.ros, pytest.mark.slow]
G = np.array([0.0, 0.0, -9.81])
DEADLINE = 180.0
#: the odometry's error: within the arrival tolerance (2 mrad here) per hand-over, a few of them
ANGLE_TOL = 0.01


def _angle(u, v) -> float:
    return math.acos(float(np.clip(np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v)), -1.0, 1.0)))


def _climb(ros_context, structure: str, steps: int, **extra):
    """The stack climbing ``steps`` steps from s = 0.2 m; the driver's supports sampled on the way."""
    nodes = climb_stack(ros_context, climb={
        'structure': structure, 'start': 0.2, 'speed': 0.05, 'auto_steps': steps, 'preview': False,
        'orientation_tolerance': 0.002, **extra})
    driver = nodes[0]
    probe = Probe(context=ros_context)
    status = probe.collect(DiagnosticStatus, 'climb/status')
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    resume = probe.create_client(Trigger, CLIMB_RESUME)
    samples, resumed = [], []

    def done() -> bool:
        samples.append(driver.hardware.support)
        last = ClimbStatus.from_key_values(status[-1].values) if status else None
        if last is not None and last.state is ClimbState.PAUSED and len(resumed) < 5 \
                and (not resumed or resumed[-1].done()):
            resumed.append(resume.call_async(Trigger.Request()))   # a stall of this loaded process
        return last is not None and (last.state is ClimbState.FAILED
                                     or (last.state is ClimbState.IDLE and last.steps_done == steps))

    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(done, DEADLINE, period=0.02), ClimbStatus.from_key_values(status[-1].values).detail
        last = ClimbStatus.from_key_values(status[-1].values)
        assert last.state is ClimbState.IDLE, last.detail
        wait_for(lambda: (samples.append(driver.hardware.support), False)[1], timeout=0.5, period=0.02)
        assert wait_for(lambda: (s := statuses(diagnostics, 'driver_node'))
                        and DriverStatus.from_key_values(s[-1].values).support_source is SupportSource.ODOMETRY)
    return samples


def _attitudes(structure, steps: int) -> dict[str, list]:
    """The planned route positions where each ring grips on the way: {ring: [s, ...]}."""
    planner = GaitPlanner(load_robot('pole_climber'), structure, loads=None)
    plan = planner.plan(steps * planner.default_step, steps, start=0.2)
    grips = {'ring_a': set(), 'ring_b': set()}
    for ph in plan.phases:
        grips['ring_a'].add(round(ph.s_a, 9))
        grips['ring_b'].add(round(ph.s_b, 9))
    return {ring: sorted(s) for ring, s in grips.items()}


def _check(samples, expected: dict, start_gravity):
    """Before the odometry: the parameters' upright gravity; after: each sample's gravity is one
    the rings take on the way (``expected``: {ring: [gravity in that ring (3,), ...]})."""
    following = [k for k, s in enumerate(samples) if not np.allclose(s.gravity_in_support, G, atol=1e-9)]
    assert following, 'the driver never left the gravity of its parameters'
    first = following[0]
    assert all(np.allclose(s.gravity_in_support, G, atol=1e-9) for s in samples[:first])
    assert _angle(samples[first].gravity_in_support, start_gravity) < ANGLE_TOL   # ring_a where it starts
    seen = set()
    for s in samples[first:]:
        errors = [_angle(s.gravity_in_support, g) for g in expected[s.ring]]
        k = int(np.argmin(errors))
        assert errors[k] < ANGLE_TOL, (s.ring, errors)
        seen.add((s.ring, k))
    return seen


def test_on_a_leaning_pole_the_gravity_is_the_lean_not_the_parameter(ros_context):
    lean = math.radians(30.0)
    samples = _climb(ros_context, 'pole', 1, structure_lean_deg=30.0)
    tilted = rotation_x(lean).T @ G                   # both rings lean with the straight pole
    seen = _check(samples, {'ring_a': [tilted], 'ring_b': [tilted]}, tilted)
    assert ('ring_b', 0) in seen                       # ring_b carried the robot (move_a) on the way
    assert _angle(tilted, G) > 10 * ANGLE_TOL


def _trunk_tangent(s: float, lean: float = 0.25) -> np.ndarray:
    """The palm trunk's centreline direction at arc length ``s``, from its defining curve (x, y)
    over height z, differentiated by hand and its arc length integrated numerically."""
    z = np.linspace(0.0, 3.0, 30001)
    dx = lean * math.pi / 6.0 * np.sin(math.pi * z / 3.0)
    dy = lean / 4.0 * (2.0 * math.pi / 3.0) * np.cos(2.0 * math.pi * z / 3.0)
    ds = np.sqrt(1.0 + dx ** 2 + dy ** 2)
    arc = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(z))])
    zs = np.interp(s, arc, z)
    t = np.array([np.interp(zs, z, dx), np.interp(zs, z, dy), 1.0])
    return t / np.linalg.norm(t)


def test_on_the_curved_palm_trunk_the_gravity_turns_as_the_rings_climb(ros_context):
    steps = 2
    trunk = make_structure('palm_trunk')
    grips = _attitudes(trunk, steps)
    expected = {ring: [trunk.grip_frame(s)[1].T @ G for s in where] for ring, where in grips.items()}
    for ring, where in grips.items():  # the ring axis' tilt is the centreline's, by hand
        for s, g in zip(where, expected[ring]):
            assert abs(_angle(-g, np.array([0.0, 0.0, 1.0])) - _angle(_trunk_tangent(s), [0.0, 0.0, 1.0])) < 2e-3
    start = expected['ring_a'][grips['ring_a'].index(0.2)]
    samples = _climb(ros_context, 'palm_trunk', steps)
    seen = _check(samples, expected, start)
    end = expected['ring_a'][grips['ring_a'].index(max(grips['ring_a']))]
    assert _angle(samples[-1].gravity_in_support, end) < ANGLE_TOL        # where ring_a grips at the end
    assert _angle(start, end) > 5 * ANGLE_TOL                              # the trunk turned the gravity
    assert {ring for ring, _ in seen} == {'ring_a', 'ring_b'}
