"""teleop_node's jerk-limited target stream over ROS: engage, a motion, a guard's halt and a
deadman release stream no velocity jump.

Every target teleop_node sends (target_pose in Cartesian mode, actuators/command in joint mode)
is turned into leg lengths here by eq. 1 written in the test (|p + R b_i - a_i|), and its speed,
acceleration and jerk are bounded by divided differences over the targets' stamps (the stream's
own times, the node's ROS clock): by the mean value theorem a k-th divided difference times k! is
the k-th derivative somewhere between its samples, so a stream within the limits gives divided
differences within them, whatever the spacing of the samples. Samples closer than
:data:`SPACING` are skipped (a subset is as good; their rounding would dominate). A k-th divided
difference may exceed its limit by its samples' rounding (:data:`ROUNDING` per leg length):
k! 2^k ROUNDING / SPACING^k.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rrps_description.motion_limits import STREAM_RATE_SHARE, STREAM_SPEED_SHARE
from rrps_runtime.messages import lengths_from_joint_state, pose_from_msg
from rrps_testing.ros_harness import wait_for
from rrps_testing.teleop_rig import MASTER, SLAVE, Rig
from rrps_testing.virtual_work import quaternion_matrix

pytestmark = [pytest.mark.ros, pytest.mark.slow]

SPACING = 0.004
#: A leg length's rounding [m] through the node's pose, the message and eq. 1 here (some hundred
#: float64 ulps of a 0.5 m length, the stamps' seconds included).
ROUNDING = 1e-14
LEGS = SLAVE.motion_limits.legs
LIMITS = (STREAM_SPEED_SHARE * LEGS.speed, STREAM_RATE_SHARE * LEGS.acceleration, STREAM_RATE_SHARE * LEGS.jerk)


def leg_lengths(position, quaternion) -> np.ndarray:
    """Eq. 1: the distance from each ring_a anchor to its ring_b anchor placed by the pose."""
    b = np.asarray(position) + np.asarray(SLAVE.ring_b_anchors) @ quaternion_matrix(quaternion).T
    return np.linalg.norm(b - np.asarray(SLAVE.ring_a_anchors), axis=1)


def derivatives(items) -> tuple[float, float, float]:
    """The largest |speed|, |acceleration|, |jerk| [m/s^k] of the legs along the stamped targets
    or commands ``items`` ((receipt, msg) pairs): k! times the k-th divided differences."""
    sec0 = min(m.header.stamp.sec for _, m in list(items))   # exact differences of the stamps
    stamped = sorted(((m.header.stamp.sec - sec0) + 1e-9 * m.header.stamp.nanosec, m) for _, m in list(items))
    keep = [stamped[0]]
    for t, m in stamped[1:]:
        if t - keep[-1][0] >= SPACING:
            keep.append((t, m))
    t = np.array([k[0] for k in keep])
    lengths = np.array([leg_lengths(*pose_from_msg(m)) if hasattr(m, 'pose') else lengths_from_joint_state(m)
                        for _, m in keep])
    d1 = np.diff(lengths, axis=0) / np.diff(t)[:, None]
    d2 = np.diff(d1, axis=0) / (t[2:] - t[:-2])[:, None]
    d3 = np.diff(d2, axis=0) / (t[3:] - t[:-3])[:, None]
    return float(np.abs(d1).max()), 2.0 * float(np.abs(d2).max()), 6.0 * float(np.abs(d3).max())


def within(items) -> tuple[float, float, float]:
    rates = derivatives(items)
    for k, (what, rate, limit) in enumerate(zip(('speed', 'acceleration', 'jerk'), rates, LIMITS), start=1):
        rounding = math.factorial(k) * 2 ** k * ROUNDING / SPACING ** k
        assert rate <= limit + rounding, (what, rate, limit, rounding)
    return rates


@pytest.mark.parametrize('mode', ['cartesian', 'joint'])
def test_engage_a_guard_halt_and_a_release_stream_within_the_legs_limits(ros_context, mode):
    """Engaged from rest, the handle jumps to where the slave's stroke halts it (the guard stops
    the command: the stream decelerates onto it), comes back, and the deadman is released while
    the slave moves (the fastest stop). Every target within the legs' speed, acceleration and
    jerk limits, and the slave at rest after each stop."""
    rig = Rig(ros_context, master=dict(trajectory='none', max_linear_speed=0.1),
              teleop=dict(mode=mode, translation_scale=8.0, joint_scale=[8.0] * 6, max_linear_speed=0.2))
    up = MASTER.home_position + [0.0, 0.0, 0.025]   # 0.2 m for the slave: past its stroke
    outputs = rig.targets if mode == 'cartesian' else rig.commands
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and rig.master_poses)
        rig.engage()
        rig.handle = (up, MASTER.home_quaternion_xyzw)
        assert wait_for(lambda: rig.code() == 'JOINT_BOUND'), rig.values()
        top = pose_from_msg(rig.wait_at_rest()[1])[0]      # held on the halted command
        rig.handle = (MASTER.home_position, MASTER.home_quaternion_xyzw)
        assert wait_for(lambda: pose_from_msg(rig.poses[-1][1])[0][2] < top[2] - 0.02)
        moving = derivatives(list(outputs)[-8:])[0]
        rig.enable = False                                 # released while moving
        assert wait_for(lambda: rig.values()['engaged'] == 'false')
        rig.wait_at_rest()
        items = list(outputs)
    assert top[2] - SLAVE.home_position[2] > 0.1           # it went as far as the stroke allows
    assert moving > 0.5 * LIMITS[0] * 0.1, moving          # released at speed
    speed, acceleration, jerk = within(items)
    print(f'\n  {mode}: {len(items)} targets, largest leg speed {speed:.4f} m/s, acceleration '
          f'{acceleration:.3f} m/s^2, jerk {jerk:.2f} m/s^3 (limits {", ".join(f"{x:g}" for x in LIMITS)})')
    assert acceleration > 0.5 * LIMITS[1]                   # the limits were reached, not idled under
