"""Following the odometry's supporting ring (rrps_hardware.support_follower) and grounding it in the
simulated hardware: a fresh message for the ring that grips sets its attitude, anything else
keeps the last known one, and the efforts are those of virtual work written independently
(rrps_testing.virtual_work) in gravity turned by the test's own rotation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.world import Support
from rrps_hardware.interface import HardwareConfig
from rrps_hardware.support_follower import SupportFollower
from rrps_interfaces.driver import SupportSource, supporting_ring
from rrps_sim.simulated_robot import SimulatedRobot
from rrps_testing.virtual_work import quaternion_matrix, rotation_x, virtual_work_forces

G = np.array([0.0, 0.0, -9.81])


def _q_x(angle: float) -> tuple:
    """The quaternion (x, y, z, w) of a turn about x, written out."""
    return (math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2))


def test_which_ring_supports_by_the_grippers():
    assert supporting_ring({'ring_a': True, 'ring_b': True}) == 'ring_a'
    assert supporting_ring({'ring_a': True, 'ring_b': False}) == 'ring_a'
    assert supporting_ring({'ring_a': False, 'ring_b': True}) == 'ring_b'
    assert supporting_ring({'ring_a': False, 'ring_b': False}) is None


def test_a_fresh_message_for_the_supporting_ring_sets_its_attitude():
    start = Support.of('ring_a')
    f = SupportFollower(start, timeout=1.0)
    assert f.report(0.0).source is SupportSource.PARAMETERS and f.update(start, 0.0) is None
    lean = math.radians(30.0)
    assert f.on_message('world', 'ring_a', _q_x(lean), 1.0)
    new = f.update(start, 1.2)
    assert new.ring == 'ring_a'
    np.testing.assert_allclose(new.gravity_in_support, rotation_x(lean).T @ G, atol=1e-12)
    assert f.report(1.2).source is SupportSource.ODOMETRY and f.report(1.2).age == pytest.approx(0.2)
    assert f.update(new, 1.3) is None                            # the same attitude: nothing to ground
    # a message within the tolerance grounds nothing either
    assert f.on_message('world', 'ring_a', _q_x(lean + 0.5 * f.tolerance), 1.4)
    assert f.update(new, 1.4) is None


def test_a_message_for_the_other_ring_or_a_stale_one_keeps_the_last_attitude():
    start = Support.of('ring_a', _q_x(0.3))
    f = SupportFollower(start, timeout=1.0)
    assert f.on_message('world', 'ring_a', _q_x(0.3), 0.0)
    handed = Support.of('ring_b', _q_x(0.5))      # the reader handed its support over itself
    assert f.update(handed, 0.1) is None            # the newest message is ring_a's: in transit
    assert f.report(0.1).source is SupportSource.HANDED_OVER
    assert f.on_message('world', 'ring_b', _q_x(0.6), 0.2)
    assert f.update(handed, 3.0) is None            # 2.8 s old: stale, never used
    report = f.report(3.0)
    assert report.stale and report.support is handed and 'stale' in report.text()
    fresh = f.on_message('world', 'ring_b', _q_x(0.6), 3.1) and f.update(handed, 3.1)
    np.testing.assert_allclose(fresh.gravity_in_support, rotation_x(0.6).T @ G, atol=1e-12)


@pytest.mark.parametrize('frame, ring, q, reason', [
    ('ring_a', 'ring_a', (0.0, 0.0, 0.0, 1.0), 'frame'),
    ('world', 'tool', (0.0, 0.0, 0.0, 1.0), 'not a ring'),
    ('world', 'ring_a', (math.nan, 0.0, 0.0, 1.0), 'finite'),
    ('world', 'ring_a', (0.0, 0.0, 0.0, 2.0), 'norm 2 is not 1'),
    ('world', 'ring_a', (0.0, 0.0, 1.0), 'shape'),
])
def test_a_malformed_message_is_rejected_and_changes_nothing(frame, ring, q, reason):
    start = Support.of('ring_a', _q_x(0.2))
    f = SupportFollower(start)
    assert not f.on_message(frame, ring, q, 0.0)
    assert f.rejected == 1 and reason in f.rejection
    assert f.update(start, 0.0) is None and f.report(0.0).source is SupportSource.PARAMETERS


def test_bad_follower_settings():
    with pytest.raises(ValueError, match='timeout'):
        SupportFollower(Support.of(), timeout=0.0)
    with pytest.raises(ValueError, match='tolerance'):
        SupportFollower(Support.of(), tolerance=math.nan)


@pytest.mark.parametrize('mode', ['kinematic', 'dynamic'])
def test_the_simulated_robot_grounds_the_odometry_attitude(mode):
    g = load_robot('pole_climber')
    sim = SimulatedRobot()
    assert sim.on_configure(HardwareConfig(g, {'time_constant': 0.0, 'mode': mode})).ok  # upright
    lean = math.radians(30.0)
    assert sim.set_support(Support.of('ring_a', _q_x(lean))).ok
    np.testing.assert_allclose(sim.support.gravity_in_support, rotation_x(lean).T @ G, atol=1e-12)
    if mode == 'kinematic':
        sim.write(0.0, 1.0, None)  # past the efforts' refresh period
        expected = virtual_work_forces(g, g.home_position, quaternion_matrix(g.home_quaternion_xyzw),
                                       rotation_x(lean).T @ G)
        np.testing.assert_allclose(sim.read(1.0, 0.01).efforts, expected, rtol=1e-5, atol=1e-3)
    refused = sim.set_support(Support.of('ring_b', _q_x(lean)))   # ring_a grips: ring_b cannot support
    assert not refused.ok and 'ring_a' in refused.message
    np.testing.assert_allclose(sim.support.gravity_in_support, rotation_x(lean).T @ G, atol=1e-12)
