"""The chain in one process: target_pose -> ik_node -> driver_node -> fk_node -> pose.

Checked: the pose returns the target (1e-6 m, 1e-6 rad) with an ideal and with the default
(lagging, speed-limited) driver and in dynamic mode; rejected and stale targets and stale or
invalid commands leave the robot where it is; the gripper interlock holds.
"""

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_kinematics import check_pose
from rrps_kinematics.nodes.fk_node import FkNode
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_testing.node_helpers import command, pose_error, said, target
from rrps_testing.ros_harness import DEADLINE, Probe, Spinner, wait_for

POLE = load_robot('pole_climber')
IDEAL = dict(time_constant=0.0, limit_speed=False, publish_on_command=True)
TOL = 1e-6

pytestmark = pytest.mark.ros


class Chain:
    def __init__(self, context, **driver_overrides):
        kw = dict(context=context, namespace='/rrps_test')
        self.ik, self.fk = IkNode(**kw), FkNode(**kw)
        driver_overrides = {'auto_activate': True, **driver_overrides}
        self.driver = DriverNode(**kw, parameter_overrides=[Parameter(k, value=v) for k, v in driver_overrides.items()])
        self.probe = Probe(**kw)
        self.poses = self.probe.collect(PoseStamped, 'pose')
        self.diagnostics = self.probe.collect(DiagnosticArray, '/diagnostics')
        self.targets = self.probe.publisher(PoseStamped, 'target_pose', command=True)
        self.commands = self.probe.publisher(JointState, 'actuators/command', command=True)
        self.nodes = [self.ik, self.fk, self.driver, self.probe]

    def ready(self):
        assert wait_for(lambda: self.poses and self.targets.get_subscription_count() == 1)

    def reach(self, position, quaternion, period=0.01):
        """Stream the target (fresh each time, at 1/period Hz, as a teleop would) until the pose
        returns it within TOL. A stall of a loaded machine may make a target stale on arrival
        (ik_node rejects it): the next one goes through, so only a generous deadline is needed."""
        def arrived():
            self.targets.publish(target(self.probe, position, quaternion))
            t, r = pose_error(self.poses[-1], position, quaternion)
            return t < TOL and r < TOL
        return wait_for(arrived, period=period)


def valid_poses(n, seed):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        p = POLE.home_position + rng.uniform(-0.03, 0.03, 3)
        q = rotation_vector_to_quat_xyzw(rng.uniform(-0.15, 0.15, 3))
        if check_pose(POLE, p, q)[0]:
            out.append((p, q))
    return out


def test_chain_returns_the_target_with_an_ideal_driver(ros_context):
    chain = Chain(ros_context, **IDEAL)
    with Spinner(ros_context, chain.nodes):
        chain.ready()
        for p, q in valid_poses(8, seed=1):
            assert chain.reach(p, q), (p, q, pose_error(chain.poses[-1], p, q))


def test_chain_with_the_default_driver_converges_on_a_streamed_target(ros_context):
    chain = Chain(ros_context)
    p, q = POLE.home_position + [0.004, -0.003, 0.005], rotation_vector_to_quat_xyzw(np.array([0.01, 0.0, -0.01]))
    with Spinner(ros_context, chain.nodes):
        chain.ready()
        assert chain.reach(p, q, period=0.02)


def test_dynamic_chain_holds_then_tracks(ros_context):
    chain = Chain(ros_context, mode='dynamic')
    p, q = POLE.home_position + [0.0, 0.004, 0.004], rotation_vector_to_quat_xyzw(np.array([0.0, 0.01, 0.0]))
    with Spinner(ros_context, chain.nodes):
        chain.ready()
        assert wait_for(lambda: len(chain.poses) > 100)
        home_errors = [pose_error(m, POLE.home_position, POLE.home_quaternion_xyzw) for m in chain.poses]
        assert max(max(e) for e in home_errors) < TOL  # holds against gravity
        assert chain.reach(p, q, period=0.02)


def test_rejected_and_stale_inputs_leave_the_robot_where_it_is(ros_context):
    chain = Chain(ros_context, **IDEAL)
    start = POLE.home_position + [0.0, 0.0, 0.01], np.array([0.0, 0.0, 0.0, 1.0])
    with Spinner(ros_context, chain.nodes):
        chain.ready()
        assert chain.reach(*start)
        probe = chain.probe
        bad_targets = [  # built when sent: each is fresh unless it is meant to be stale
            (lambda: target(probe, [np.nan, 0.0, 0.4]), 'ik_node', 'NaN'),
            (lambda: target(probe, start[0], frame_id='world'), 'ik_node', 'frame_id'),
            (lambda: target(probe, start[0], [0.0, 0.0, 0.2, 1.0]), 'ik_node', 'quaternion norm'),
            (lambda: target(probe, start[0] + [0.0, 0.0, 0.3]), 'ik_node', 'stroke'),
            (lambda: target(probe, start[0] + [0.0, 0.0, 0.005], age=1.0), 'ik_node', 'stale'),
        ]
        bad_commands = [
            (lambda: command(probe, POLE.home_lengths, age=1.0), 'driver_node', 'stale'),
            (lambda: command(probe, [0.4] * 5 + [np.inf]), 'driver_node', 'NaN'),
            (lambda: command(probe, [0.9] * 6), 'driver_node', 'stroke'),
        ]
        def send(make):
            msg = make()
            (chain.targets if isinstance(msg, PoseStamped) else chain.commands).publish(msg)

        for make, node, text in bad_targets + bad_commands:
            n, k = len(chain.poses), len(chain.diagnostics)
            # Sent (fresh) until the node says why it refused it (in a status published after the
            # first send): a message that a stall of a loaded machine delivered late is refused
            # as stale first, not for its content.
            assert wait_for(lambda: (send(make), said(chain.diagnostics[k:], node, text))[1], period=0.05), text
            assert wait_for(lambda: len(chain.poses) > n + 20)  # the driver keeps publishing
            for m in chain.poses[n:]:
                assert max(pose_error(m, *start)) < TOL, text


def test_gripper_interlock_in_the_chain(ros_context):
    chain = Chain(ros_context, **IDEAL)
    sets = {ring: chain.probe.create_client(SetBool, f'grippers/{ring}/set') for ring in ('ring_a', 'ring_b')}

    def call(ring, close):
        future = sets[ring].call_async(SetBool.Request(data=close))
        assert wait_for(future.done)
        return future.result().success

    with Spinner(ros_context, chain.nodes):
        chain.ready()
        assert all(c.wait_for_service(timeout_sec=DEADLINE) for c in sets.values())
        assert call('ring_a', False)                      # ring_a lets go, ring_b grips
        assert not call('ring_b', False)                  # refused: nothing would grip
        assert chain.reach(POLE.home_position + [0.0, 0.0, 0.01], [0, 0, 0, 1])   # step while ring_b grips
        assert call('ring_a', True)                       # ring_a closes in its gripper_time
        assert wait_for(lambda: chain.driver.state.grippers['ring_a'], DEADLINE)
        assert call('ring_b', False) and not call('ring_a', False)
        assert wait_for(lambda: not chain.driver.state.grippers['ring_b'], DEADLINE)
    assert chain.driver.state.grippers == {'ring_a': True, 'ring_b': False}
