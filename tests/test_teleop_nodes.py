"""Teleoperation over ROS, launch-free: master_node and teleop_node with the IK, FK and driver nodes.

Every node runs in-process under the namespace /rrps on a private domain id (ros_context). The
operator is a Probe: it holds the deadman (teleop/enable at 20 Hz), moves the master's handle,
or stands in for the master robot itself (publishing master/pose and master/actuators/state
sample by sample) where a test needs to control exactly which master sample produced a command.
"""

import contextlib
import threading
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from ros_harness import Probe, Spinner, wait_for
from rrps_kinematics import check_pose, inverse_kinematics, load_robot
from rrps_kinematics.nodes.common import (COMMAND_QOS, joint_state_msg, lengths_from_joint_state,
                                          pose_from_msg, pose_to_msg, stamp_to_seconds)
from rrps_kinematics.nodes.fk_node import FkNode
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_sim.nodes.driver_node import DriverNode
from rrps_teleop.interfaces import ClimbState, ClimbStatus
from rrps_teleop.master import scripted_pose
from rrps_teleop.nodes.master_node import MasterNode
from rrps_teleop.nodes.teleop_node import TeleopNode

pytestmark = pytest.mark.ros

SLAVE = load_robot('pole_climber')
MASTER = load_robot('master_robot')
NS = '/rrps'


def params(**values):
    return [Parameter(k, value=v) for k, v in values.items()]


class Rig:
    """The slave chain (teleop → IK → driver → FK), optionally the master node, and the operator probe."""

    def __init__(self, ctx, *, master=None, teleop=None):
        self.probe = Probe(context=ctx, namespace=NS)
        p = self.probe
        self.targets = p.collect(PoseStamped, 'target_pose', qos=COMMAND_QOS, stamped=True)
        self.commands = p.collect(JointState, 'actuators/command', qos=COMMAND_QOS, stamped=True)
        self.poses = p.collect(PoseStamped, 'pose', stamped=True)
        self.master_poses = p.collect(PoseStamped, 'master/pose', stamped=True)
        self.status = p.collect(DiagnosticStatus, 'teleop/status', stamped=True)
        self.enable_pub = p.publisher(Bool, 'teleop/enable', command=True)
        self.handle_pub = p.publisher(PoseStamped, 'master/target_pose', command=True)
        self.master_pose_pub = p.publisher(PoseStamped, 'master/pose')
        self.master_state_pub = p.publisher(JointState, 'master/actuators/state')
        self.climb_pub = p.publisher(DiagnosticStatus, 'climb/status')
        self.enable = False
        self.handle = None  # where the operator holds the master's handle (position, quaternion)
        # Unless a test is about them, timeouts far above any stall of a loaded 2-core machine, so
        # that a stall never re-clutches in the middle of a test.
        teleop = {'master_timeout': 1.0, 'enable_timeout': 1.0} | (teleop or {})
        self.teleop = TeleopNode(context=ctx, namespace=NS, parameter_overrides=params(**teleop))
        nodes = [self.teleop, IkNode(context=ctx, namespace=NS), FkNode(context=ctx, namespace=NS),
                 DriverNode(context=ctx, namespace=NS,
                            parameter_overrides=params(rate=100.0, auto_activate=True))]
        if master is not None:
            self.master = MasterNode(context=ctx, namespace=NS,
                                     parameter_overrides=params(**({'rate': 100.0} | master)))
            nodes.append(self.master)
        self.nodes = nodes + [p]

    @contextlib.contextmanager
    def spin(self, ctx):
        """Spin every node; the operator's deadman (``enable``: True, False or None = silent) and
        handle are published at 20 Hz from their own thread, as the viewer does."""
        stop = threading.Event()

        def deadman():
            while not stop.wait(0.05):
                if self.enable is not None:
                    self.enable_pub.publish(Bool(data=self.enable))
                if self.handle is not None:
                    self.handle_pub.publish(pose_to_msg(*self.handle, frame_id='master_ring_a',
                                                        stamp=self.probe.get_clock().now().to_msg()))
        thread = threading.Thread(target=deadman, daemon=True)
        with Spinner(ctx, self.nodes):
            thread.start()
            try:
                yield self
            finally:
                stop.set()
                thread.join()

    def code(self):
        return self.status[-1][1].message if self.status else None

    def values(self):
        return {kv.key: kv.value for kv in self.status[-1][1].values}

    def engage(self, timeout=3.0):
        self.enable = True
        assert wait_for(lambda: self.status and self.values()['engaged'] == 'true', timeout), self.code()

    def publish_master(self, position, quaternion):
        """Stand in for the master robot: one encoder sample and its pose."""
        stamp = self.probe.get_clock().now().to_msg()
        lengths = inverse_kinematics(MASTER, position, quaternion).lengths
        self.master_state_pub.publish(joint_state_msg(stamp, lengths))
        self.master_pose_pub.publish(pose_to_msg(position, quaternion, frame_id='master_ring_a', stamp=stamp))
        return lengths


def target_position(item):
    return pose_from_msg(item[1])[0]


def test_the_slave_follows_a_scripted_master_within_the_scale(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='lissajous', amplitude=0.004, period=8.0))
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and len(rig.master_poses) > 10, 5.0)
        rig.engage()
        n0, s0 = len(rig.targets), len(rig.status)
        time.sleep(2.0)
        targets = rig.targets[n0:]
        masters = list(rig.master_poses)
        codes = {s[1].message for s in rig.status[s0:]}
    assert len(targets) > 100  # one target per master sample (100 Hz)
    # A loaded machine may stall the executor beyond max_period: the slave then lags for a step.
    assert 'NO_WARNING' in codes and codes <= {'NO_WARNING', 'SPEED_LIMITED'}, codes
    # Each target came from the latest master sample stamped before it (message-triggered control):
    m_stamps = np.array([stamp_to_seconds(m[1].header.stamp) for m in masters])
    m_pos = np.array([pose_from_msg(m[1])[0] for m in masters])
    ref_t = targets[0]
    ref_m = m_pos[np.searchsorted(m_stamps, stamp_to_seconds(ref_t[1].header.stamp), 'right') - 1]
    errors = []
    for t in targets[1:]:
        k = np.searchsorted(m_stamps, stamp_to_seconds(t[1].header.stamp), 'right') - 1
        errors.append(np.linalg.norm((target_position(t) - target_position(ref_t)) - 4.0 * (m_pos[k] - ref_m)))
    moved = np.linalg.norm(target_position(targets[-1]) - target_position(ref_t))
    assert moved > 0.005
    # Within the scale: exact for the matched sample; a sample overtaken on the way or a step
    # speed-limited after a stall of the loaded machine costs at most a few master periods.
    assert np.median(errors) < 1e-9 and np.percentile(errors, 90) < 1e-6, (np.median(errors), max(errors))
    assert max(errors) < 2e-3
    # The measured slave pose (FK of the driver's lengths) tracks the last target closely.
    assert np.linalg.norm(pose_from_msg(rig.poses[-1][1])[0] - target_position(targets[-1])) < 3e-3


def test_clutch_causes_no_jump(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='circle', amplitude=0.004, period=4.0))
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and len(rig.master_poses) > 10, 5.0)
        rig.engage()
        time.sleep(0.8)
        rig.enable = False
        assert wait_for(lambda: rig.values()['engaged'] == 'false', 1.0)
        n_release = len(rig.targets)
        held = target_position(rig.targets[-1])
        time.sleep(1.0)  # the master goes on a quarter turn: 5.7 mm, 23 mm for the slave
        assert len(rig.targets) == n_release
        measured = pose_from_msg(rig.poses[-1][1])[0]
        rig.engage()
        time.sleep(0.5)
        targets = list(rig.targets)
    first = target_position(targets[n_release])
    # The first target after the clutch is where the slave is: no jump.
    assert np.linalg.norm(first - measured) < 1e-6
    assert np.linalg.norm(first - held) < 2e-3  # the driver's lag behind the last target, no more
    # Never a jump: no step beyond the speed limit over the longest step time (0.05 m/s x 0.05 s).
    steps = [np.linalg.norm(target_position(b) - target_position(a)) for a, b in zip(targets, targets[1:])]
    assert max(steps) <= 0.05 * 0.05 + 1e-9, max(steps)


def stamp_of(item):
    return stamp_to_seconds(item[1].header.stamp)


def test_deadman_release_and_lapse_hold_the_slave_within_0_1_s(ros_context):
    """Times are the commands' stamps (when teleop_node computed them) against the probe's clock
    (the same system clock), so a loaded machine's transport delays do not count."""
    rig = Rig(ros_context, master=dict(trajectory='circle', amplitude=0.004, period=4.0),
              teleop=dict(enable_timeout=0.2, master_timeout=0.1))
    now = lambda: rig.probe.get_clock().now().nanoseconds * 1e-9
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and len(rig.master_poses) > 10, 5.0)
        rig.engage()
        time.sleep(0.5)
        # Released: teleop/enable false (the operator lets go of the button).
        rig.enable = False
        t_release = now()
        rig.enable_pub.publish(Bool(data=False))
        time.sleep(0.6)
        last_after_release = rig.commands[-1]
        rig.engage()
        time.sleep(0.5)
        # Lapsed: no teleop/enable at all any more (a dead operator console).
        rig.enable = None
        t_lapse = now()  # the last true was published at most 0.05 s before
        time.sleep(0.8)
        last_after_lapse = rig.commands[-1]
        poses_end = [pose_from_msg(p[1])[0] for p in rig.poses[-20:]]
    assert stamp_of(last_after_release) - t_release < 0.1
    assert stamp_of(last_after_lapse) - t_lapse < 0.2 + 0.1  # enable_timeout, then held within 0.1 s
    assert stamp_of(last_after_lapse) - t_lapse > 0.1  # it did follow until the timeout
    assert np.ptp(poses_end, axis=0).max() < 1e-9  # held, no drift


@pytest.mark.parametrize('control', ['message', 'timer'])
def test_master_dropout_holds_the_slave_within_0_1_s(ros_context, control):
    # The probe is the master; the slave lags (slow speed limit), so without a hold it would go on.
    rig = Rig(ros_context, teleop=dict(control=control, max_linear_speed=0.01, master_timeout=0.1))
    sample_stamps = []
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses, 5.0)
        t0 = time.monotonic()
        rig.enable = True

        def sample():
            p, q = scripted_pose('circle', time.monotonic() - t0, MASTER.home_position,
                                 MASTER.home_quaternion_xyzw, amplitude=0.006, period=2.0)
            sample_stamps.append(rig.probe.get_clock().now().nanoseconds * 1e-9)
            rig.publish_master(p, q)
        timer = rig.probe.create_timer(0.01, sample)
        assert wait_for(lambda: rig.status and rig.values()['engaged'] == 'true', 3.0)
        time.sleep(0.5)
        assert rig.code() == 'SPEED_LIMITED'
        rig.probe.destroy_timer(timer)
        assert wait_for(lambda: rig.code() == 'MASTER_STALE', 1.0)
        time.sleep(0.4)
        last = rig.targets[-1]
    t_drop = sample_stamps[-1]
    # Message-triggered control stops with the last sample; a timer keeps stepping towards the
    # last sample until master_timeout, then holds.
    bound = 0.05 if control == 'message' else 0.1 + 0.05
    assert stamp_of(last) - t_drop < bound, stamp_of(last) - t_drop


def test_guards_stop_an_unreachable_request_and_let_it_come_back(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='none', max_linear_speed=0.1),
              teleop=dict(translation_scale=8.0, max_linear_speed=0.2))
    up = MASTER.home_position + [0.0, 0.0, 0.025]  # reachable for the master, 0.2 m for the slave
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and rig.master_poses, 5.0)
        rig.engage()
        rig.handle = (up, MASTER.home_quaternion_xyzw)
        assert wait_for(lambda: rig.code() == 'JOINT_BOUND', 8.0), (
            rig.values(), pose_from_msg(rig.master_poses[-1][1])[0], pose_from_msg(rig.poses[-1][1])[0])
        time.sleep(0.3)
        top = pose_from_msg(rig.poses[-1][1])[0]
        blocked_values = rig.values()
        rig.handle = (MASTER.home_position, MASTER.home_quaternion_xyzw)
        assert wait_for(lambda: pose_from_msg(rig.poses[-1][1])[0][2] < top[2] - 0.01, 5.0)
        targets, commands = list(rig.targets), list(rig.commands)
    assert 'stroke margin' in blocked_values['detail']
    assert 0.0 <= float(blocked_values['margin_stroke']) < 0.01
    for _, msg in targets:
        assert check_pose(SLAVE, *pose_from_msg(msg))[0]
    lengths = np.array([lengths_from_joint_state(m) for _, m in commands])
    assert lengths.max() <= SLAVE.max_length and lengths.min() >= SLAVE.min_length
    assert top[2] - SLAVE.home_position[2] > 0.1  # it went as far as the stroke allows


def _ping_pong_run(ros_context, mode):
    """The probe is the master: one sample, wait for a command, next. Returns (master L published, commands)."""
    rig = Rig(ros_context, teleop=dict(mode=mode))
    published = []
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses, 5.0)
        rig.enable = True
        time.sleep(0.1)
        for k in range(80):
            p, q = scripted_pose('lissajous', 0.01 * k, MASTER.home_position, MASTER.home_quaternion_xyzw,
                                 amplitude=0.004, period=8.0, angular_amplitude=0.04)
            n = len(rig.commands)
            published.append(rig.publish_master(p, q))
            wait_for(lambda: len(rig.commands) > n, 1.0)
            time.sleep(0.01)
        commands = [lengths_from_joint_state(m) for _, m in rig.commands]
        codes = [(round(t, 3), s.message) for t, s in rig.status]
    return np.array(published), np.array(commands), codes


def test_joint_space_mode_matches_cartesian_mode_for_the_similar_master(ros_context):
    runs = {mode: _ping_pong_run(ros_context, mode) for mode in ('cartesian', 'joint')}
    for mode, (published, commands, codes) in runs.items():
        assert len(commands) > 60, mode
        assert not {c for _, c in codes} & {'SPEED_LIMITED', 'INVALID'}, (mode, codes)
        # Both follow L_slave = 4 L_master (master_robot = pole_climber / 4, engaged at home): the
        # joint map without FK, the Cartesian map through the master's FK, scale 4 and slave IK.
        # Every command is that of one master sample (a loaded machine may drop or delay some).
        errors = np.abs(commands[:, None, :] - 4.0 * published[None, :, :]).max(axis=2).min(axis=1)
        assert errors.max() < 1e-6, (mode, errors.max())
    moved = np.abs(runs['cartesian'][1][-1] - SLAVE.home_lengths).max()
    assert moved > 0.004


def test_parameters_are_validated_at_run_time_and_a_change_is_a_clutch(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='none'))
    client = rig.probe.create_client(SetParameters, f'{NS}/teleop_node/set_parameters')

    def set_param(name, value, kind):
        field = {ParameterType.PARAMETER_DOUBLE: 'double_value',
                 ParameterType.PARAMETER_STRING: 'string_value'}[kind]
        request = SetParameters.Request(parameters=[ParameterMsg(
            name=name, value=ParameterValue(type=kind, **{field: value}))])
        future = client.call_async(request)
        assert wait_for(future.done, 3.0)
        return future.result().results[0]

    with rig.spin(ros_context):
        assert client.wait_for_service(timeout_sec=3.0)
        assert wait_for(lambda: rig.poses and rig.master_poses, 5.0)
        rig.engage()
        for value in (0.0, -2.0, float('nan'), float('inf')):
            result = set_param('translation_scale', value, ParameterType.PARAMETER_DOUBLE)
            assert not result.successful, value
        result = set_param('mode', 'velocity', ParameterType.PARAMETER_STRING)
        assert not result.successful and 'mode must be one of' in result.reason
        result = set_param('translation_scale', 2.0, ParameterType.PARAMETER_DOUBLE)
        assert result.successful
        assert wait_for(lambda: rig.values()['scale'] == '2' and rig.values()['engaged'] == 'true', 2.0)
        engaged_flags = [s[1].values for s in rig.status]
    assert rig.teleop.mapping.config.translation_scale == 2.0
    # The change released the clutch (engaged false) before engaging again.
    flags = [{kv.key: kv.value for kv in v}['engaged'] for v in engaged_flags]
    assert 'true' in flags and flags[-1] == 'true'
    assert any(a == 'true' and b == 'false' for a, b in zip(flags, flags[1:]))


def test_no_engage_while_a_climb_step_executes(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='circle'))
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and rig.master_poses, 5.0)
        values = ClimbStatus(state=ClimbState.EXECUTING).to_values()  # as the climb node writes it
        rig.climb_pub.publish(DiagnosticStatus(name='climb_node', message='executing', values=[
            KeyValue(key=k, value=v) for k, v in values.items()]))
        rig.enable = True
        assert wait_for(lambda: rig.code() == 'CLIMB_EXECUTING', 2.0), rig.code()
        time.sleep(0.3)
        assert not rig.targets and rig.values()['engaged'] == 'false'
        values = ClimbStatus(state=ClimbState.IDLE).to_values()
        rig.climb_pub.publish(DiagnosticStatus(name='climb_node', message='idle', values=[
            KeyValue(key=k, value=v) for k, v in values.items()]))
        assert wait_for(lambda: rig.targets, 2.0)


def test_master_node_follows_the_handle_within_its_limits_and_rejects_bad_targets(ros_context):
    from diagnostic_msgs.msg import DiagnosticArray
    master = MasterNode(context=ros_context, namespace=NS, parameter_overrides=params(rate=100.0))
    probe = Probe(context=ros_context, namespace=NS)
    states = probe.collect(JointState, 'master/actuators/state')
    poses = probe.collect(PoseStamped, 'master/pose')
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    handle = probe.publisher(PoseStamped, 'master/target_pose', command=True)
    said = lambda text: any(text in s.message for d in diagnostics for s in d.status)  # noqa: E731

    def send(position, quaternion=(0.0, 0.0, 0.0, 1.0), frame='master_ring_a'):
        msg = pose_to_msg(position, quaternion, frame_id=frame, stamp=probe.get_clock().now().to_msg())
        handle.publish(msg)

    goal = MASTER.home_position + [0.003, 0.0, 0.002]
    with Spinner(ros_context, [master, probe]):
        assert wait_for(lambda: poses and handle.get_subscription_count(), 5.0)
        np.testing.assert_allclose(lengths_from_joint_state(states[-1]), MASTER.home_lengths, atol=1e-12)
        assert wait_for(lambda: (send(goal), np.allclose(pose_from_msg(poses[-1])[0], goal, atol=1e-9))[1], 3.0)
        # Encoders and FK agree: master/pose is the FK of master/actuators/state.
        np.testing.assert_allclose(lengths_from_joint_state(states[-1]),
                                   inverse_kinematics(MASTER, goal, [0, 0, 0, 1]).lengths, atol=1e-9)
        for args, text in ((([0.0, 0.0, 0.2], (0, 0, 0, 1), 'world'), 'frame_id'),
                           (([0.0, np.nan, 0.1],), 'NaN'),
                           (([0.0, 0.0, 0.1], (0, 0, 0, 3)), 'quaternion norm 3 is not 1')):
            assert wait_for(lambda: (send(*args), said(text))[1], 3.0), text
        np.testing.assert_allclose(pose_from_msg(poses[-1])[0], goal, atol=1e-9)
        # Far beyond the stroke: the handle stops on the master's own limits.
        assert wait_for(lambda: (send(MASTER.home_position + [0.0, 0.0, 0.2]), said('stopped at the limits'))[1],
                        5.0)
        assert check_pose(MASTER, *pose_from_msg(poses[-1]))[0]
        assert master.set_parameters([Parameter('trajectory', value='square')])[0].successful is False
        assert master.set_parameters([Parameter('trajectory', value='circle')])[0].successful


def test_teleop_node_rejects_malformed_master_data_and_says_why(ros_context):
    teleop = TeleopNode(context=ros_context, namespace=NS)
    probe = Probe(context=ros_context, namespace=NS)
    status = probe.collect(DiagnosticStatus, 'teleop/status')
    pose_pub = probe.publisher(PoseStamped, 'master/pose')
    state_pub = probe.publisher(JointState, 'master/actuators/state')
    said = lambda text: any(s.message == 'INVALID' and text in {kv.key: kv.value for kv in s.values}['detail']
                            for s in status)  # noqa: E731
    stamp = lambda: probe.get_clock().now().to_msg()  # noqa: E731
    with Spinner(ros_context, [teleop, probe]):
        assert wait_for(lambda: pose_pub.get_subscription_count() and state_pub.get_subscription_count(), 5.0)
        pose_pub.publish(pose_to_msg(MASTER.home_position, [0, 0, 0, 1], frame_id='world', stamp=stamp()))
        assert wait_for(lambda: said("frame_id 'world'"), 3.0)
        pose_pub.publish(pose_to_msg([0.0, 0.0, np.inf], [0, 0, 0, 1], frame_id='master_ring_a', stamp=stamp()))
        assert wait_for(lambda: said('NaN or infinite'), 3.0)
        state_pub.publish(joint_state_msg(stamp(), [0.1] * 5, names=['leg_1', 'leg_2', 'leg_3', 'leg_4', 'leg_5']))
        assert wait_for(lambda: said("missing joints ['leg_6']"), 3.0)
    assert not teleop.mapping.engaged
