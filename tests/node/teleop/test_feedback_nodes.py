"""Limits felt on the master over ROS: the teleop node's master/feedback and the master's yielding.

The operator lifts the master's handle so that the slave climbs towards its maximum stroke:
the feedback wrench appears, grows as the slave nears the limit and points back inside (down);
the simulated master yields to it (its pose stays below the handle).
"""

from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped

from rrps_interfaces.teleop import TeleopStatus
from rrps_kinematics import check_pose
from rrps_runtime.messages import pose_from_msg
from rrps_runtime.qos import COMMAND_QOS
from rrps_testing.ros_harness import wait_for
from rrps_testing.teleop_rig import SLAVE, Rig

pytestmark = [pytest.mark.ros, pytest.mark.slow]
DEADLINE = 60.0


def test_the_feedback_grows_towards_the_stroke_limit_and_the_master_yields(ros_context):
    rig = Rig(ros_context, master={'max_linear_speed': 0.02},
              teleop={'translation_scale': 4.0, 'max_linear_speed': 0.08})
    feedback = rig.probe.collect(WrenchStamped, 'master/feedback', qos=COMMAND_QOS, stamped=True)
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and rig.master_poses, DEADLINE)
        p0, q0 = pose_from_msg(rig.master_poses[-1][1])
        rig.handle = (p0, q0)
        rig.engage()
        samples = []  # (slave stroke margin, feedback force z)
        for k in range(1, 40):
            rig.handle = (p0 + [0.0, 0.0, 0.001 * k], q0)   # the handle goes up 1 mm at a time
            n = len(feedback)
            assert wait_for(lambda: len(feedback) > n + 2, DEADLINE)
            slave_p, slave_q = pose_from_msg(rig.poses[-1][1])
            margin = float(check_pose(SLAVE, slave_p, slave_q)[2].minimum['stroke'])
            samples.append((margin, feedback[-1][1].wrench.force.z, feedback[-1][1].header.frame_id))
            status = TeleopStatus.from_key_values(rig.status[-1][1].values)
            if margin < 0.004:
                break
        margins = np.array([m for m, _, _ in samples])
        force_z = np.array([f for _, f, _ in samples])
        assert all(frame == 'master_ring_a' for _, _, frame in samples)
        assert margins[-1] < 0.015, 'the slave did not approach its stroke limit'
        far = force_z[margins > 0.03]
        near = force_z[margins < 0.01]
        assert far.size and near.size
        assert np.all(np.abs(far) < 1e-9)           # nothing deep inside (activation 0.02 m)
        assert np.all(near < 0.0)                  # points back inside: down, away from max stroke
        assert near.min() < far.min() - 0.5        # grows towards the limit [N]
        assert status.feedback_limit == 'stroke' and status.feedback_force > 0.5
        # the master yields: its pose stays below where the operator holds the handle
        master_z = pose_from_msg(rig.master_poses[-1][1])[0][2]
        assert rig.handle[0][2] - master_z > 1e-4
