"""What the climb node sends of the supporting ring (climbing.odometry_attitude): the ring the
grippers say, at once on a change and at a heartbeat otherwise; and a plan anchored on the
odometry moves rigidly (its a_T_b paths untouched)."""

from __future__ import annotations

import math

import numpy as np

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.odometry_attitude import SupportPublisher, anchor_phases, support_of_odometry
from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.structures import make_structure


def test_the_supporting_ring_of_the_odometry():
    a, b = Pose((0.0, 0.0, 1.0)), Pose((0.0, 0.0, 1.2))
    assert support_of_odometry(a, b, {'ring_a': True, 'ring_b': True}) == ('ring_a', a)
    assert support_of_odometry(a, b, {'ring_a': False, 'ring_b': True}) == ('ring_b', b)
    assert support_of_odometry(a, b, {'ring_a': False, 'ring_b': False}) is None
    assert support_of_odometry(a, b, None) is None


def test_sent_at_once_on_a_change_else_at_the_heartbeat():
    due = SupportPublisher(period=0.1)
    a = Pose((0.0, 0.0, 1.0))
    assert due.due('ring_a', a, 0.0)
    assert not due.due('ring_a', a, 0.05)
    assert due.due('ring_a', a, 0.11)                                 # the heartbeat
    assert due.due('ring_b', a, 0.12)                                 # another ring: at once
    turned = Pose((0.0, 0.0, 1.0), (math.sin(1e-4), 0.0, 0.0, math.cos(1e-4)))
    assert due.due('ring_b', turned, 0.13)                            # another attitude: at once
    assert not due.due('ring_b', turned, 0.14)


def test_an_anchored_plan_moves_rigidly_onto_the_odometry():
    planner = GaitPlanner(load_robot('pole_climber'), make_structure('palm_trunk'), loads=None)
    phases = planner.plan(planner.default_step, 1, start=0.2).phases
    odometry = Pose((0.01, -0.02, 0.21), (math.sin(0.01), 0.0, 0.0, math.cos(0.01))) @ phases[0].world_T_a
    anchored = anchor_phases(phases, odometry)
    assert np.allclose(anchored[0].world_T_a.matrix, odometry.matrix, atol=1e-12)
    shift = odometry.matrix @ np.linalg.inv(phases[0].world_T_a.matrix)   # the test's own correction
    for ph, new in zip(phases, anchored):
        np.testing.assert_allclose(new.world_T_a.matrix, shift @ ph.world_T_a.matrix, atol=1e-12)
        np.testing.assert_allclose(new.world_T_b.matrix, shift @ ph.world_T_b.matrix, atol=1e-12)
        assert new.path is ph.path                                     # what the robot executes
    assert anchor_phases(phases, None) == phases
