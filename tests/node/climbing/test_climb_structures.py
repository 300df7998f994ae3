"""Climbing over ROS on the palm trunk and on the structural frame, as for the pole.

With ``junction_deg`` the climb node crosses the frame's node bent by that angle
(``climbing.frame_node``). On the frame the climb node commands the extra ring DOF (paper section 3.1, Figure 9): the
ring angles go through the IK node (``target_rings``) to the driver as the named joints
``ring_a_rotation`` / ``ring_b_rotation`` of ``actuators/command`` and come back in
``actuators/state``; the odometry uses the measured angles.
"""

from __future__ import annotations

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.gait import GaitPlanner
from rrps_description.geometry import load_robot
from rrps_description.structures import make_structure
from rrps_interfaces.climb import CLIMB_RESUME, ClimbState, ClimbStatus
from rrps_runtime.messages import pose_from_msg
from rrps_runtime.qos import COMMAND_QOS
from rrps_testing.climb_resume import Resumer
from rrps_testing.climb_stack import climb_stack
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow]
DEADLINE = 120.0
TOL = 1e-3


def _climb(ros_context, robot: str, structure: str, start: float, **extra):
    nodes = climb_stack(ros_context, robot, driver={'rate': 100.0, 'ring_rotation_speed': 3.0},
                        climb={'structure': structure, 'start': start, 'speed': 0.08, 'auto_steps': 1, **extra})
    climb = nodes[-1]
    probe = Probe(context=ros_context)
    logs = {'status': probe.collect(DiagnosticStatus, 'climb/status'),
            'commands': probe.collect(JointState, 'actuators/command', qos=COMMAND_QOS),
            'states': probe.collect(JointState, 'actuators/state'),
            'odo_a': probe.collect(PoseStamped, 'odometry/ring_a'),
            'odo_b': probe.collect(PoseStamped, 'odometry/ring_b')}

    def done() -> bool:
        s = [ClimbStatus.from_key_values(m.values) for m in logs['status']]
        return any(x.state is ClimbState.IDLE and x.steps_done == 1 for x in s) \
            or any(x.state is ClimbState.FAILED for x in s)

    client = probe.create_client(Trigger, CLIMB_RESUME)
    resumer = Resumer(lambda: client.call_async(Trigger.Request()))

    def done_or_resumed() -> bool:
        resumer(ClimbStatus.from_key_values(logs['status'][-1].values) if logs['status'] else None)
        return done()

    with Spinner(ros_context, nodes + [probe]):
        assert wait_for(done_or_resumed, DEADLINE), \
            ClimbStatus.from_key_values(logs['status'][-1].values)
        wait_for(lambda: False, timeout=0.3)
    if resumer.calls:
        print(f'the step paused and was resumed {len(resumer.calls)} time(s)')
    states = [ClimbStatus.from_key_values(m.values) for m in logs['status']]
    assert not any(x.state is ClimbState.FAILED for x in states), states[-1].detail
    return climb, logs


def test_the_pole_climber_climbs_the_palm_trunk_over_ros(ros_context):
    climb, logs = _climb(ros_context, 'pole_climber', 'palm_trunk', start=0.2)
    planner = GaitPlanner(load_robot('pole_climber'), make_structure('palm_trunk'))
    plan = planner.plan(planner.default_step, 1, start=0.2)
    end = plan.phases[-1]
    pa = pose_from_msg(logs['odo_a'][-1])[0]
    assert np.linalg.norm(pa - end.world_T_a.position) < 4 * TOL   # where the plan says, on the trunk
    assert climb.s_a == pytest.approx(end.s_a)


def test_the_frame_climber_turns_its_ring_over_ros_at_a_junction(ros_context):
    start = 1.3  # one step across the turned junction: ring_b's extra DOF turns by 90 degrees
    climb, logs = _climb(ros_context, 'frame_climber', 'frame', start=start)
    planner = GaitPlanner(load_robot('frame_climber'), make_structure('frame'))
    plan = planner.plan(planner.default_step, 1, start=start)
    theta_b = plan.phases[-1].theta_b
    assert abs(theta_b) > 1.0
    commanded = [dict(zip(m.name, m.position)) for m in logs['commands']]
    assert any('ring_b_rotation' in c for c in commanded)              # through actuators/command
    rings = [c['ring_b_rotation'] for c in commanded if 'ring_b_rotation' in c]
    assert max(abs(r) for r in rings) == pytest.approx(abs(theta_b), abs=1e-6)
    measured = dict(zip(logs['states'][-1].name, logs['states'][-1].position))
    assert measured['ring_b_rotation'] == pytest.approx(theta_b, abs=1e-3)  # the driver turned it
    assert climb.measured_angles[1] == pytest.approx(theta_b, abs=1e-3)    # the odometry reads it
    pb = pose_from_msg(logs['odo_b'][-1])[0]
    assert np.linalg.norm(pb - plan.phases[-1].world_T_b.position) < 4 * TOL


def test_the_frame_climber_crosses_a_90_deg_node_over_ros(ros_context):
    climb, logs = _climb(ros_context, 'frame_climber', 'frame', start=-1.0, junction_deg=90.0)
    plan = FrameNodePlanner(load_robot('frame_climber'), 90.0).plan_crossing()
    end = plan.phases[-1]
    assert (climb.s_a, climb.machine.s_b) == pytest.approx((end.s_a, end.s_b))  # past the node
    measured = dict(zip(logs['states'][-1].name, logs['states'][-1].position))
    for ring, theta in (('ring_a', end.theta_a), ('ring_b', end.theta_b)):
        assert abs(theta) == pytest.approx(np.pi / 2)                   # both grippers turned 90 deg
        assert measured[f'{ring}_rotation'] == pytest.approx(theta, abs=1e-3)
    pa, pb = pose_from_msg(logs['odo_a'][-1])[0], pose_from_msg(logs['odo_b'][-1])[0]
    assert np.linalg.norm(pa - end.world_T_a.position) < 4 * TOL    # on the second beam, as planned
    assert np.linalg.norm(pb - end.world_T_b.position) < 4 * TOL
