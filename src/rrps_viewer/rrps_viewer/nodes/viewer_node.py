"""viewer_node: the viser web viewer for remote operators (docs/viewer.md; topics: docs/usage.md, "The ROS
interface"; parameters: docs/parameters.md).

ROS callbacks only store the latest messages; drawing runs in the viewer's own thread at ``render_rate`` Hz, and
browser requests run on the executor's thread (the ``enable_rate`` timer), so every rclpy call stays on one thread.
Safety: binds ``host`` (127.0.0.1), read-only until a browser enters ``token``, one operator at a time; a
disconnected operator loses control and the deadman stops, so the robot holds.
"""

from __future__ import annotations

import math
import queue
import secrets
import threading
import time

import numpy as np
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64

from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.structures import structure_from_parameters
from rrps_interfaces.climb import CLIMB_PREVIEW, CLIMB_STATUS, odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, TARGET_POSE
from rrps_interfaces.link import SOURCES
from rrps_interfaces.teleop import (
    MASTER_FEEDBACK,
    MASTER_POSE,
    MASTER_TARGET_POSE,
    OPERATOR_ROUND_TRIP,
    TELEOP_ENABLE,
    TELEOP_STATUS,
    ViewerStatus,
)
from rrps_runtime.diagnostics import OK, OPERATOR_STATION, Diagnostics
from rrps_runtime.messages import pose_to_msg, stamp_to_seconds
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATEST_QOS
from rrps_runtime.scheduling import scheduling_parameters
from rrps_runtime.supervision import OPERATOR_RT_PRIORITY
from rrps_viewer import Frame, ViewerServer, send_file
from rrps_viewer import status_text as panel
from rrps_viewer._workspace import WorkspaceView
from rrps_viewer.operator_requests import OperatorRequest, ViewerRequests
from rrps_viewer.picture import Picture
from rrps_viewer.recording_clients import ViewerRecording
from rrps_viewer.robot_subscriptions import DRIVER, FK, ViewerRobots

#: Queued browser requests for the recording side (the others are OperatorRequests).
_RECORDING = object()

#: viewer_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('viewer_node', 'rrps_viewer', [
    ROBOT,
    Parameter('master_robot', 'master_robot', 'master robot to draw (shipped name or YAML path; empty: none)'),
    Parameter('host', '127.0.0.1', 'address the web server binds (0.0.0.0: every interface)'),
    Parameter('port', 8080, 'web server port', range=(1, 65535)),
    Parameter('token', '', 'operator token (empty: generate one)'),
    Parameter('render_rate', 40.0, 'scene updates per second', unit='Hz', range=(1.0, 120.0)),
    Parameter('enable_rate', 20.0, 'teleop/enable and master/target_pose rate', unit='Hz', range=(10.0, 100.0)),
    Parameter('deadman_timeout', 0.25, 'deadman expiry after the last hold event', unit='s', range=(0.05, 2.0)),
    Parameter('master_origin', (0.0, -0.9, 0.0), 'world position of the master robot console', unit='m'),
    Parameter('structure', 'pole', 'structure to draw (pole, palm_trunk, frame, facade; empty: none)'),
    Parameter('structure_length', 3.0, 'length of the drawn structure', unit='m', range=(0.5, 100.0)),
    Parameter('structure_lean_deg', 0.0, "the drawn pole's lean from the vertical", unit='deg', range=(-80.0, 80.0)),
    Parameter('junction_deg', 0.0, "frame: its member bent by this angle at the node", unit='deg', range=(0.0, 90.0)),
    Parameter('out_of_plane', False, "frame: the member bends normal to the column's web plane"),
    Parameter('workspace_resolution', 0.02, 'grid of the reachable workspace drawn around the robot; 0: not '
              'drawn', unit='m', range=(0.0, 0.2)),
    Parameter('workspace_payload_max', 100.0, 'top of the payload slider of the load-feasible workspace '
              '(a payload on ring_b, ring_a gripping); 0: no slider', unit='kg', range=(0.0, 1e4)),
    Parameter('plot_window', 20.0, 'leg-length plot window', unit='s', range=(1.0, 600.0)),
    Parameter('robot_topics', 'direct', "read the robots' state from their own topics (direct) or from their "
              'link relays (link)', choices=SOURCES),
    Parameter('robots', ('',), "the namespaces of the robots (a fleet's: /robot_1, ...; '': the viewer's own), "
              'the first drawn at start', item_type=str),
    *scheduling_parameters(OPERATOR_RT_PRIORITY),  # executor and websocket carry the deadman; drawing stays normal
])


class ViewerNode(Node):
    """The web viewer and remote-operator console; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('viewer_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        master_name = values['master_robot']
        self.master_geometry = load_robot(master_name) if master_name else None
        host, port, token = values['host'], values['port'], values['token']
        render_rate, enable_rate = values['render_rate'], values['enable_rate']
        deadman_timeout, origin = values['deadman_timeout'], values['master_origin']
        resolution = values['workspace_resolution']
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise ValueError(f'master_origin must be 3 finite numbers, got {list(origin)}')
        self.workspace = WorkspaceView(self.geometry, resolution=resolution) if resolution else None
        self.token = token or secrets.token_urlsafe(12)
        if len(self.token) < 8:
            raise ValueError('token must have at least 8 characters')

        from rrps_viewer._control import OperatorControl
        self.control = OperatorControl(token=self.token, deadman_timeout=deadman_timeout)
        self._lock = threading.Lock()
        self._latest: dict[str, object] = {}
        self._odometry_rings = {odometry_topic(ring): ring for ring in ('ring_a', 'ring_b')}
        self._pose_count = 0
        self._report_window = (time.monotonic(), 0, 0)
        self._actions: queue.SimpleQueue = queue.SimpleQueue()
        self._master_target: Pose | None = None
        self._false_left = 0
        self._master_origin = Pose(np.asarray(origin, dtype=float))
        #: the picture, drawn in the viewer's thread (:mod:`rrps_viewer.picture`)
        self.picture = Picture(self.geometry, self.master_geometry, self._master_origin, self.workspace,
                               values['plot_window'], self.get_logger())
        self._panel_text, self._panel_time = '', -1.0

        self._enable_pub = self.create_publisher(Bool, TELEOP_ENABLE, COMMAND_QOS)
        self._master_pub = self.create_publisher(PoseStamped, MASTER_TARGET_POSE, COMMAND_QOS)
        self.create_subscription(PoseStamped, MASTER_POSE, lambda msg: self._store(MASTER_POSE, msg), LATEST_QOS)
        self.create_subscription(WrenchStamped, MASTER_FEEDBACK,
                                 lambda msg: self._store(MASTER_FEEDBACK, msg), COMMAND_QOS)
        self.robots = ViewerRobots(self, values['robots'], values['robot_topics'], self._on_drawn)
        self.requests = ViewerRequests(self, tell=lambda c, m, ok: self.viewer.tell(c, m, ok=ok),
                                       robot=self.robots.selected)
        self.requests.on_switch = self._switched
        self._diag = Diagnostics(self, 'viewer', hardware_id=OPERATOR_STATION, rate_hz=1.0)
        self.create_timer(1.0, self._report)
        self._round_trip_pub = self.create_publisher(Float64, OPERATOR_ROUND_TRIP, COMMAND_QOS)
        self.recording = ViewerRecording(  # "Save last 60 s", the replay timeline
            self, tell=lambda c, m, ok: self.viewer.tell(c, m, ok=ok),
            send_file=lambda c, name, content: send_file(self.viewer.server, c, name, content))
        self.create_timer(1.0 / enable_rate, self._tick)

        self.viewer = ViewerServer(
            host=host, port=port, control=self.control, actions=self, frame_source=self.frame,
            geometry=self.geometry, master_geometry=self.master_geometry,
            master_origin=self._master_origin,
            structure=structure_from_parameters(values).mesh() if values['structure'] else None, rate=render_rate,
            title=f'rrps · {self.geometry.name}', payload_max=values['workspace_payload_max'] if resolution else 0.0,
            robots=[self.robots.name(r) for r in self.robots.robots] if len(self.robots.robots) > 1 else ())
        shown = '127.0.0.1' if host in ('0.0.0.0', '::', '') else host
        self.url = f'http://{shown}:{self.viewer.port}'
        self.get_logger().info(f'viewer at {self.url} (bound to {host}); operator token: {self.token}')

    # --- ROS callbacks (store only) ----------------------------------------------------------

    def _store(self, key: str, msg) -> None:
        with self._lock:
            self._latest[key] = msg
        ring = self._odometry_rings.get(key)
        if ring is not None:
            self.picture.add_to_trail(ring, msg)

    def _on_drawn(self, topic: str, msg) -> None:
        """A message of the drawn robot (``nodes/viewer_robots``)."""
        if topic == ACTUATORS_STATE:
            self._on_state(msg)
            return
        if topic == POSE:
            self._pose_count += 1
        self._store(topic, msg)

    def _on_state(self, msg: JointState) -> None:
        """Keep the newest actuators/state; it is read at the drawing rate (``Picture.read_state``)."""
        with self._lock:
            self._latest[ACTUATORS_STATE] = msg

    def _switched(self, namespace: str) -> None:
        """The teleop node drives the robot in ``namespace`` now: draw it, send its requests to
        it, and release the clutch and the deadman (the operator engages again on purpose)."""
        robot = next((r for r in self.robots.robots if self.robots.absolute(r) == namespace), None)
        if robot is None or robot == self.robots.selected:
            return
        self.robots.select(robot)
        self.requests.select(robot)
        self.control.release_clutch()
        with self._lock:
            for key in (POSE, TARGET_POSE, ACTUATORS_STATE, *self._odometry_rings):
                self._latest.pop(key, None)
        self.picture.clear()
        self.viewer.refresh_all()

    def _report(self) -> None:
        """ViewerStatus on /diagnostics: frames drawn and the drawn robot's pose rate and age."""
        t0, frames0, poses0 = self._report_window
        now = time.monotonic()
        frames = self.viewer.frames_drawn
        dt = max(now - t0, 1e-3)
        self._report_window = (now, frames, self._pose_count)
        with self._lock:
            pose = self._latest.get(POSE)
        age = (None if pose is None else
               round(1e3 * (self.get_clock().now().nanoseconds * 1e-9 - stamp_to_seconds(pose.header.stamp)), 1))
        self._diag.report(OK, f'drawing {self.robots.name(self.robots.selected)}', ViewerStatus(
            robots=len(self.robots.robots), heard=self.robots.heard_count(2.0),
            drawn=self.robots.absolute(self.robots.selected),
            draw_rate=round((frames - frames0) / dt, 1), pose_rate=round((self._pose_count - poses0) / dt, 1),
            pose_age_ms=age, clients=len(self.control.clients())))

    # --- the picture (drawing thread) ---------------------------------------------------------

    def frame(self) -> Frame:
        """The latest picture: robot, ghost, master, grippers, trails, panel and plot."""
        with self._lock:
            latest = dict(self._latest)
        latest[ACTUATORS_STATE] = self.picture.read_state(latest.get(ACTUATORS_STATE))
        summary = self.robots.latest()
        latest.update({key: summary.get(key) for key in (TELEOP_STATUS, CLIMB_STATUS, CLIMB_PREVIEW, GRIPPERS_STATE)})
        latest['driver'], fk_status = summary.get(DRIVER), summary.get(FK)
        frame = self.picture.draw(latest, self.recording.replay_status())
        now = time.monotonic()
        if now - self._panel_time >= 0.25:  # text for people: 4 Hz
            self._panel_text, self._panel_time = self._panel(latest, frame, fk_status), now
        frame.panel = self._panel_text
        return frame

    def _panel(self, latest: dict, frame: Frame, fk_status) -> str:
        """The status panel (markdown), from the typed statuses (viewer/status_text)."""
        teleop = latest.get(TELEOP_STATUS)
        lines = [f'**Driver:** {panel.driver_line(latest.get("driver"))}',
                 f'**Teleop:** {panel.teleop_line(teleop)}',
                 f'**Climb:** {panel.climb_line(latest.get(CLIMB_STATUS))}',
                 f'**Preview:** {panel.preview_line(latest.get(CLIMB_PREVIEW))}',
                 f'**Round trip:** {panel.round_trip_line(self.round_trip())}',
                 f'**Grippers:** {panel.grippers_line(frame.grippers)}']
        if frame.slave is not None:
            lines += panel.slave_lines(frame.slave, min_conditioning=self.geometry.min_conditioning)
        feedback = panel.feedback_line(teleop)
        if feedback is not None:
            lines.append(f'**Feedback on the master:** {feedback}')
        ws = frame.workspace
        if ws is not None and frame.slave is not None:
            a_T_b = frame.slave.world_T_a.inverse() @ frame.slave.world_T_b
            lines.append(f'**Workspace:** {ws.describe(a_T_b.position)}')
        if fk_status is not None:
            lines.append(f'**FK:** {panel.fk_line(fk_status)}')
        now = self.get_clock().now().nanoseconds * 1e-9
        ages = []
        state = latest.get(ACTUATORS_STATE)
        if state is not None:
            ages.append(f'state {1e3 * (now - state[2]):.1f} ms')
        if latest.get(POSE) is not None:
            ages.append(f'FK pose {1e3 * (now - stamp_to_seconds(latest[POSE].header.stamp)):.1f} ms')
        lines.append('**Latency:** ' + (', '.join(ages) if ages else 'no data yet'))
        if len(self.robots.robots) > 1:
            lines += self.robots.panel_lines()
        controller = self.control.controller
        lines.append(f'**Operators:** {len(self.control.clients())} viewer(s); control: '
                     f'{"free" if controller is None else f"operator {controller}"}; '
                     f'deadman {"ON" if self.control.enable() else "off"}')
        return '  \n'.join(lines)

    # --- operator actions (viser threads -> queue -> executor thread) ---------------------------

    def select_robot(self, client_id: int, name: str) -> None:
        """Drive the robot called ``name`` (a fleet): asks the teleop node to switch."""
        robot = next((r for r in self.robots.robots if self.robots.name(r) == name), None)
        if robot is None:
            self.viewer.tell(client_id, f'unknown robot {name!r}', ok=False)
            return
        self._actions.put((OperatorRequest.ROBOT, client_id, self.robots.absolute(robot)))

    def step(self, client_id: int, direction: str) -> None:
        kind = OperatorRequest.STEP_UP if direction == 'up' else OperatorRequest.STEP_DOWN
        self._actions.put((kind, client_id, None))

    def set_gripper(self, client_id: int, ring: str, close: bool) -> None:
        self._actions.put((OperatorRequest.GRIPPER, client_id, (ring, close)))

    def set_mapping(self, client_id: int, mode: str, rotation_mode: str, scale: float) -> None:
        self._actions.put((OperatorRequest.MAPPING, client_id, (mode, rotation_mode, scale)))

    def set_driver_active(self, client_id: int, active: bool) -> None:
        self._actions.put((OperatorRequest.DRIVER, client_id, active))

    def set_workspace_payload(self, client_id: int, mass: float) -> None:
        if self.workspace is not None:  # the drawn load-feasible workspace: the viewer's own
            self.workspace.set_payload(mass)

    def resume_climb(self, client_id: int) -> None:
        self._actions.put((OperatorRequest.RESUME, client_id, None))

    def save_flight_recording(self, client_id: int) -> None:
        self._actions.put((_RECORDING, client_id, ('save',)))

    def replay_control(self, client_id: int, **changes) -> None:
        self._actions.put((_RECORDING, client_id, ('replay', changes)))

    def round_trip(self) -> float | None:
        """The controlling browser's round trip [s] (None: no controller or not measured yet)."""
        controller = self.control.controller
        return None if controller is None else self.viewer.links.round_trip(controller)

    def master_target(self, client_id: int, world_T_handle: Pose | None) -> None:
        """The gizmo moved (or was removed: None). Streamed by the timer while control is held."""
        with self._lock:
            self._master_target = world_T_handle

    def _tick(self) -> None:
        rtt = self.round_trip()
        if rtt is not None:  # the teleop node slows down above 0.2 s and holds above 0.3 s
            self._round_trip_pub.publish(Float64(data=rtt))
        enable = self.control.enable()
        if enable:
            self._enable_pub.publish(Bool(data=True))
            self._false_left = 5
        elif self._false_left > 0:  # a few explicit falses, then silence (stale = hold)
            self._enable_pub.publish(Bool(data=False))
            self._false_left -= 1
        with self._lock:
            target = self._master_target
        if target is not None and self.control.controller is not None:
            in_master = self._master_origin.inverse().compose(target)
            self._master_pub.publish(pose_to_msg(in_master.position, in_master.quaternion_xyzw,
                                                 frame_id='master_ring_a',
                                                 stamp=self.get_clock().now().to_msg()))
        while True:
            try:
                kind, client_id, arg = self._actions.get_nowait()
            except queue.Empty:
                break
            if not self.control.may_control(client_id):
                self.viewer.tell(client_id, 'read-only: you do not have control', ok=False)
                continue
            if kind is _RECORDING:
                self.recording.handle(client_id, arg)
            else:
                self.requests.send(kind, client_id, arg)
        self.recording.poll()

    def destroy_node(self) -> None:
        self.viewer.stop()
        self.requests.close()
        super().destroy_node()


def main(args=None) -> None:
    run_nodes([ViewerNode], args)


if __name__ == '__main__':
    main()
