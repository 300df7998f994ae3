"""The web viewer's picture of the drawn robot, built in the drawing thread from its newest messages: the slave placed
by its gripping ring's odometry (ring_a at the world origin before any), the ghost, the master with its feedback, the
workspace on both, the trails and the leg-length plot."""

from __future__ import annotations

import collections
import math
import threading
import time

import numpy as np
from sensor_msgs.msg import JointState

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_interfaces.climb import odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE
from rrps_interfaces.teleop import MASTER_FEEDBACK, MASTER_POSE, TELEOP_STATUS
from rrps_kinematics.scene import FigureCache, Trail, world_ring_poses
from rrps_runtime.messages import lengths_from_joint_state, pose_from_msg, stamp_to_seconds
from rrps_viewer import Frame
from rrps_viewer import status_text as panel
from rrps_viewer._workspace import WorkspaceView

__all__ = ['FEEDBACK_ARROW', 'PLOT_PERIOD', 'Picture']

#: Length of the drawn master/feedback arrow per newton [m/N].
FEEDBACK_ARROW = 0.01
#: The leg-length plot is redrawn this often [s] (its arrays are built only then).
PLOT_PERIOD = 0.2


class Picture:
    """The picture of ``geometry``'s robot and the master (``master_geometry``, None: not drawn)
    at ``master_origin``; ``workspace`` (None: not drawn); the plot keeps ``plot_window`` [s];
    ``logger`` warns of messages that cannot be drawn."""

    def __init__(self, geometry: RobotGeometry, master_geometry: RobotGeometry | None, master_origin: Pose,
                 workspace: WorkspaceView | None, plot_window: float, logger):
        self.geometry, self.master_geometry, self.master_origin = geometry, master_geometry, master_origin
        self.workspace = workspace
        self._plot_window = plot_window
        self._logger = logger
        self._lock = threading.Lock()
        self._t0 = time.monotonic()
        self._plot_t: collections.deque = collections.deque()
        self._plot_l: collections.deque = collections.deque()
        self._plot_time = -math.inf
        self._trails = {'ring_a': Trail(), 'ring_b': Trail()}
        self._figure = FigureCache()
        self._state_read: tuple = (None, None)

    def add_to_trail(self, ring: str, msg) -> None:
        """A ring's odometry (PoseStamped, frame world) extends its trail (ROS callbacks)."""
        position, _ = pose_from_msg(msg)
        if np.all(np.isfinite(position)):
            with self._lock:
                self._trails[ring].add(position)

    def clear(self) -> None:
        """Another robot is drawn: forget the trails and the plot."""
        with self._lock:
            self._trails = {ring: Trail() for ring in self._trails}
            self._plot_t.clear()
            self._plot_l.clear()

    def read_state(self, msg: JointState | None):
        """(lengths, efforts or None, stamp [s]) of an actuators/state, or None; the leg-length
        plot takes a sample every 0.05 s. Called by the drawing thread only."""
        if msg is None:
            return None
        if msg is self._state_read[0]:
            return self._state_read[1]
        try:
            lengths = lengths_from_joint_state(msg)
        except ValueError as exc:
            self._logger.warn(f'actuators/state ignored: {exc}', throttle_duration_sec=5.0)
            self._state_read = (msg, None)
            return None
        efforts = None
        if len(msg.effort) == len(msg.name) and msg.name:
            index = {n: i for i, n in enumerate(msg.name)}
            efforts = np.array([msg.effort[index[f'leg_{i}']] for i in range(1, 7)])
        state = (lengths, efforts, stamp_to_seconds(msg.header.stamp))
        self._state_read = (msg, state)
        now = time.monotonic() - self._t0
        with self._lock:
            if not self._plot_t or now - self._plot_t[-1] >= 0.05:
                self._plot_t.append(now)
                self._plot_l.append(lengths)
                while self._plot_t and now - self._plot_t[0] > self._plot_window:
                    self._plot_t.popleft()
                    self._plot_l.popleft()
        return state

    @staticmethod
    def gripping(grippers: dict) -> str:
        """The ring the robot hangs on: ring_a unless only ring_b is known closed."""
        if grippers.get('ring_a', 1.0) is not None and grippers.get('ring_a', 1.0) >= 0.5:
            return 'ring_a'
        return 'ring_b' if (grippers.get('ring_b') or 0.0) >= 0.5 else 'ring_a'

    def draw(self, latest: dict, replay) -> Frame:
        """The picture of the newest messages (``latest`` by topic, actuators/state as read by
        :meth:`read_state`) and the replay's status."""
        now = time.monotonic()
        with self._lock:
            plot = None  # the plot is redrawn at 5 Hz: its arrays only then
            if now - self._plot_time >= PLOT_PERIOD and len(self._plot_t) >= 2:
                plot, self._plot_time = (np.array(self._plot_t), np.array(self._plot_l)), now
            trails = {ring: trail.points for ring, trail in self._trails.items()}
        grippers: dict[str, float | None] = {'ring_a': None, 'ring_b': None}
        gripper_msg = latest.get(GRIPPERS_STATE)
        if gripper_msg is not None:
            for name, value in zip(gripper_msg.name, gripper_msg.position):
                if name in grippers and math.isfinite(value):
                    grippers[name] = float(value)
        frame = Frame(grippers=grippers, trails=trails, plot=plot, replay=replay)
        state = latest.get(ACTUATORS_STATE)
        efforts = state[1] if state is not None else None
        pose_msg = latest.get(POSE)
        world_T_a = None
        if pose_msg is not None:
            try:
                a_T_b = Pose(*pose_from_msg(pose_msg))
                gripping = self.gripping(grippers)
                odom = latest.get(odometry_topic(gripping))
                world_T_g = Pose(*pose_from_msg(odom)) if odom is not None else None
                if world_T_g is None:  # no odometry yet: ring_a at the world origin
                    gripping, world_T_g = 'ring_a', Pose()
                world_T_a, _ = world_ring_poses(a_T_b=a_T_b, gripping=gripping,
                                                world_T_gripping=world_T_g)
                frame.slave = self._figure('slave', self.geometry, a_T_b, world_T_a, efforts)
            except ValueError as exc:
                self._logger.warn(f'cannot draw pose: {exc}', throttle_duration_sec=5.0)
        target = latest.get(TARGET_POSE)
        if target is not None and world_T_a is not None:
            try:
                frame.ghost_world_T_b = world_T_a.compose(Pose(*pose_from_msg(target)))
            except ValueError:
                pass
        master_msg = latest.get(MASTER_POSE)
        if master_msg is not None and self.master_geometry is not None:
            try:
                m_pose = Pose(*pose_from_msg(master_msg))
                frame.master = self._figure('master', self.master_geometry, m_pose,
                                            self.master_origin, None)
                frame.master_handle = frame.master.world_T_b
                feedback = latest.get(MASTER_FEEDBACK)
                if feedback is not None:
                    f = feedback.wrench.force
                    force = self.master_origin.rotation @ np.array([f.x, f.y, f.z])
                    start = frame.master.world_T_b.position
                    frame.master_feedback = np.stack([start, start + FEEDBACK_ARROW * force])
            except ValueError:
                pass
        self._add_workspace(frame, latest)
        return frame

    def _add_workspace(self, frame: Frame, latest: dict) -> None:
        """The reachable workspace at the slave's orientation (computed in the background), and
        its copy on the master through the Cartesian mapping: a slave position p is reached
        when the master is at pm + (p - ps) / scale (pm, ps the current poses)."""
        if self.workspace is None or frame.slave is None:
            return
        a_T_b = frame.slave.world_T_a.inverse() @ frame.slave.world_T_b
        self.workspace.request(a_T_b.quaternion_xyzw, frame.slave.world_T_a.quaternion_xyzw)
        frame.workspace = self.workspace.latest()
        master_msg = latest.get(MASTER_POSE)
        if frame.workspace is None or master_msg is None or self.master_geometry is None:
            return
        scale = panel.translation_scale(latest.get(TELEOP_STATUS))
        pm, _ = pose_from_msg(master_msg)
        frame.master_workspace = (pm - a_T_b.position / scale, scale)
