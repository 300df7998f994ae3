"""ClimbStepMachine without ROS: pauses and resumes of a step (a lost input, an inactive driver, a
robot moved or stopped behind the stream while paused, a pause longer than settle_timeout) and the
release gate, in the simulated system of :class:`rrps_testing.climb_rig.ClimbRig`.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from rrps_description.pose import Pose, pose_error
from rrps_interfaces.climb import PauseReason
from rrps_testing.climb_rig import DT, EXECUTING, IDLE, PAUSED, POLE, ClimbRig, assert_brakes, in_phase, started


def _goes_on_from(rig: ClimbRig, pose) -> None:
    """After a resume the stream goes on from ``pose``: its first target one period on from there,
    at most at the path speed of the legs' speed limit (ring_b moves along the pole, the legs
    within 25 deg of it); the step then ends idle, never with both grippers open."""
    first = rig.tick().target.a_T_b
    assert 0.0 < pose_error(pose, first)[0] <= POLE.max_speed / np.cos(np.radians(25)) * DT
    rig.run_until(lambda s: s.state is IDLE)
    assert rig.machine.steps_done == 1 and not rig.both_open


@pytest.mark.parametrize('cause, reason, timeout', [
    ('state', PauseReason.ROBOT_STATE_LOST, 0.2),
    ('operator', PauseReason.OPERATOR_LINK_LOST, 0.5),
    ('driver_active', PauseReason.DRIVER_INACTIVE, 0.0),
])
def test_a_lost_input_pauses_the_step_until_it_is_resumed(cause, reason, timeout):
    rig = ClimbRig()                                     # step 1's move_b takes about 1.4 s
    started(rig)
    rig.run_until(lambda s: in_phase('move_b')(s) and s.step == 1)
    for _ in range(5):
        rig.tick()
    setattr(rig, cause, False)
    t_lost = rig.t
    streamed = [o.target for o in rig.run_until(lambda s: s.state is not EXECUTING) if o.target is not None]
    paused = rig.outputs[-1][1].status
    assert paused.state is PAUSED and paused.pause_reason is reason and paused.phase == 'move_b'
    assert timeout <= rig.t - t_lost <= timeout + 2 * DT
    assert rig.outputs[-1][1].log[0][0] == logging.ERROR and reason.value in paused.detail
    held = [rig.tick() for _ in range(50)]               # 1 s: braking along the path, then holding
    assert all(out.gripper is None for out in held)
    if reason is PauseReason.DRIVER_INACTIVE:            # the driver holds the legs itself
        assert all(out.target is None for out in held) and 'braking' not in paused.detail
    else:
        assert_brakes(streamed, held) and 'braking along the path, then holding' in paused.detail
    held_at = rig.pose                                   # the last target
    refused = rig.call(rig.machine.resume)
    assert not refused.reply[0] and reason.value in refused.reply[1]

    setattr(rig, cause, True)                            # the cause is gone: still paused
    assert all(out.target is None for out in [rig.tick() for _ in range(20)])
    assert rig.machine.status().state is PAUSED
    resumed = rig.call(rig.machine.resume)
    assert resumed.reply == (True, 'resumed at step 1, phase move_b')
    assert resumed.status.state is EXECUTING and resumed.status.pause_reason is None
    _goes_on_from(rig, held_at)


def test_a_robot_moved_while_paused_is_not_resumed():
    rig = ClimbRig()
    started(rig)
    rig.run_until(in_phase('move_b'))
    rig.driver_active = False
    rig.run_until(lambda s: s.state is PAUSED)
    rig.driver_active = True
    rig.pose = Pose(rig.pose.position + [0.02, 0.0, 0.0], rig.pose.quaternion_xyzw)
    rig.tick()
    refused = rig.call(rig.machine.resume)
    assert not refused.reply[0] and 'off the paused path' in refused.reply[1]
    assert rig.machine.status().state is PAUSED
    idle = ClimbRig()
    assert idle.call(idle.machine.resume).reply == (False, 'refused: the climb is idle')


def test_a_robot_stopped_behind_the_stream_resumes_from_where_it_stands():
    """A drive fault stops the robot while the stream runs on until the pause is known (on a
    loaded machine 0.3 s: 14 mm in a CANopen run): the robot stands on the path behind the paused
    target, and the stream goes on from the path's sample nearest to it, not with a jump."""
    rig = ClimbRig()
    started(rig)
    rig.run_until(lambda s: in_phase('move_b')(s) and s.step == 1)
    for _ in range(10):
        rig.tick()
    stopped, rig.track = rig.pose, False            # the robot stops here; the stream runs on
    for _ in range(15):
        rig.tick()
    ahead = rig.outputs[-1][1].target.a_T_b
    assert pose_error(stopped, ahead)[0] > 0.01 > 10 * rig.machine.config.position_tolerance / 2
    rig.driver_active = False
    rig.run_until(lambda s: s.state is PAUSED)
    rig.driver_active, rig.track = True, True
    rig.tick()
    resumed = rig.call(rig.machine.resume)
    assert resumed.reply == (True, 'resumed at step 1, phase move_b')
    _goes_on_from(rig, stopped)


def test_a_release_waits_for_the_operator_link_heard_since_the_robot_settled():
    rig = ClimbRig()
    started(rig)
    rig.run_until(in_phase('release_b'))
    rig.operator = False                                 # the link drops as the release phase starts
    rig.run_until(lambda s: s.state is not EXECUTING)
    assert rig.machine.status().pause_reason is PauseReason.OPERATOR_LINK_LOST
    assert rig.machine.status().phase == 'release_b'     # held in the release, not after it
    assert rig.requests() == [] and rig.grippers['ring_b']
    rig.operator = True
    rig.tick()
    assert rig.call(rig.machine.resume).reply[0]
    rig.run_until(lambda s: s.state is not EXECUTING or not rig.grippers['ring_b'])
    assert [(r.ring, r.close) for _, r in rig.requests()] == [('ring_b', False)]


def test_a_pause_longer_than_settle_timeout_does_not_fail_the_phase_on_resume():
    rig = ClimbRig(settle_timeout=0.5)
    started(rig)
    rig.run_until(in_phase('release_b'))
    rig.driver_active = False
    rig.run_until(lambda s: s.state is PAUSED)
    for _ in range(50):                                  # paused 1 s, twice settle_timeout
        rig.tick()
    rig.driver_active = True
    rig.tick()
    assert rig.call(rig.machine.resume).reply[0]
    rig.run_until(lambda s: s.state is not EXECUTING)
    assert rig.machine.status().state is IDLE and rig.machine.steps_done == 1
