"""The teleoperation chain in one process, for tests and benchmarks: teleop_node, ik_node,
fk_node and driver_node (optionally master_node) under /rrps, with an operator probe that holds
the deadman, moves the master's handle or stands in for the master robot sample by sample."""

import contextlib
import threading
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.duration import Duration
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from rrps_description.geometry import load_robot
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.nodes.fk_node import FkNode
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_runtime.messages import joint_state_msg, pose_from_msg, pose_to_msg
from rrps_runtime.qos import COMMAND_QOS
from rrps_teleop.master import scripted_pose
from rrps_teleop.nodes.master_node import MasterNode
from rrps_teleop.nodes.teleop_node import TeleopNode
from rrps_testing.ros_harness import IN_PROCESS_COMMAND_TIMEOUT, Probe, Spinner, header_time, params, wait_for

__all__ = ['SLAVE', 'MASTER', 'NS', 'params', 'Rig']

SLAVE = load_robot('pole_climber')
MASTER = load_robot('master_robot')
NS = '/rrps'


class Rig:
    """The slave chain (teleop → IK → driver → FK), optionally the master node, and the operator probe."""

    def __init__(self, ctx, *, master=None, teleop=None, driver_rate=100.0):
        self.probe = Probe(context=ctx, namespace=NS)
        p = self.probe
        # (receipt time on the ROS clock, message): receipt times compare with header stamps.
        self.targets = p.collect(PoseStamped, 'target_pose', qos=COMMAND_QOS, stamped=True, clock='ros')
        self.commands = p.collect(JointState, 'actuators/command', qos=COMMAND_QOS, stamped=True, clock='ros')
        self.poses = p.collect(PoseStamped, 'pose', stamped=True, clock='ros')
        self.master_poses = p.collect(PoseStamped, 'master/pose', stamped=True, clock='ros')
        self.status = p.collect(DiagnosticStatus, 'teleop/status', stamped=True, clock='ros')
        self.enables = p.collect(Bool, 'teleop/enable', qos=COMMAND_QOS, stamped=True, clock='ros')
        self.enable_pub = p.publisher(Bool, 'teleop/enable', command=True)
        self.handle_pub = p.publisher(PoseStamped, 'master/target_pose', command=True)
        self.master_pose_pub = p.publisher(PoseStamped, 'master/pose')
        self.master_state_pub = p.publisher(JointState, 'master/actuators/state')
        self.climb_pub = p.publisher(DiagnosticStatus, 'climb/status')
        self.enable = False
        self.handle = None  # where the operator holds the master's handle (position, quaternion)
        # Unless a test is about them, timeouts far above any stall of a loaded machine, so that a
        # stall never re-clutches in the middle of a test (docs/tests.md, "Tests on a
        # loaded machine").
        teleop = {'master_timeout': 5.0, 'enable_timeout': 5.0, 'state_timeout': 5.0} | (teleop or {})
        self.teleop = TeleopNode(context=ctx, namespace=NS, parameter_overrides=params(**teleop))
        # ... and the same for the driver's and IK's stale commands (ros_harness.IN_PROCESS_COMMAND_TIMEOUT)
        timeout = IN_PROCESS_COMMAND_TIMEOUT
        nodes = [self.teleop, IkNode(context=ctx, namespace=NS, parameter_overrides=params(timeout=timeout)),
                 FkNode(context=ctx, namespace=NS),
                 DriverNode(context=ctx, namespace=NS,
                            parameter_overrides=params(rate=driver_rate, auto_activate=True, timeout=timeout))]
        self.driver_rate = driver_rate
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

    def engage(self):
        self.enable = True
        assert wait_for(lambda: self.status and self.values()['engaged'] == 'true'), self.code()

    def follow(self, n=20):
        """Wait until ``n`` more targets came (the slave is being driven)."""
        k = len(self.targets)
        assert wait_for(lambda: len(self.targets) >= k + n), (len(self.targets) - k, self.code())

    def statuses_after(self, t):
        """(receipt time, code, values) of every teleop/status received after ``t`` [s, ROS clock]."""
        return [(r, s.message, {kv.key: kv.value for kv in s.values}) for r, s in list(self.status) if r > t]

    def wait_for_master_time(self, t):
        """Wait until a master sample stamped after ``t`` came: the master went on until then."""
        assert wait_for(lambda: self.master_poses and header_time(self.master_poses[-1]) > t)

    def wait_at_rest(self, n=20):
        """Wait until the last ``n`` measured poses are one pose (the slave stands still); return it."""
        def still():
            last = [pose_from_msg(m)[0] for _, m in self.poses[-n:]]
            return len(last) == n and np.ptp(last, axis=0).max() < 1e-9
        assert wait_for(still), pose_from_msg(self.poses[-1][1])
        return self.poses[-1]

    def last_command_stamp(self):
        """The latest stamp of the slave commands: target_pose (teleop_node's computing time) and
        actuators/command (carrying its target's stamp, or teleop_node's own in joint mode)."""
        return max(header_time(m) for m in list(self.targets) + list(self.commands))

    def stream_master(self, *, running=lambda: True, delay=lambda: 0.0) -> None:
        """Stand in for a moving master from now on: every 10 ms while ``running()``, a sample of
        its handle on a 6 mm circle (2 s a turn), stamped ``delay()`` s before now."""
        t0 = time.monotonic()

        def sample() -> None:
            if running():
                p, q = scripted_pose('circle', time.monotonic() - t0, MASTER.home_position,
                                     MASTER.home_quaternion_xyzw, amplitude=0.006, period=2.0)
                self.publish_master(p, q, delay=delay())
        self.probe.create_timer(0.01, sample)

    def publish_master(self, position, quaternion, delay: float = 0.0):
        """Stand in for the master robot: one encoder sample and its pose, stamped ``delay`` s
        before now (a sample that the transport held back)."""
        stamp = (self.probe.get_clock().now() - Duration(seconds=delay)).to_msg()
        lengths = inverse_kinematics(MASTER, position, quaternion).lengths
        self.master_state_pub.publish(joint_state_msg(stamp, lengths))
        self.master_pose_pub.publish(pose_to_msg(position, quaternion, frame_id='master_ring_a', stamp=stamp))
        return lengths
