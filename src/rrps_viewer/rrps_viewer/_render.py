"""The viser rendering layer: scene nodes, the status panel and the plot (the per-browser operator controls are in
``_operator_panel``).

Scene names, all in the ``world`` frame (REP-103, z up): ``/structure``, ``/robot/ring_a|ring_b``, ``/robot/legs``,
``/robot/grippers/ring_a|ring_b``, ``/ghost/ring_b``, ``/master/...``, ``/trail/ring_a|ring_b`` and, per browser
holding control, ``/operator/master_handle``. Drawing runs in this module's own thread at ``rate`` Hz.
"""

from __future__ import annotations

import asyncio
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import viser
import viser.uplot

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_kinematics.scene import RobotFigure
from rrps_runtime.scheduling import INPUT_THREAD, name_thread
from rrps_viewer._broadcast import install as install_shared_encoding
from rrps_viewer._camera import FirstView
from rrps_viewer._control import OperatorControl
from rrps_viewer._latency import LinkMonitor
from rrps_viewer._operator_panel import ClientControls, OperatorActions
from rrps_viewer._scene import build_scene, draw_robot
from rrps_viewer._workspace import WorkspaceSnapshot

__all__ = ['Frame', 'ViewerServer']

#: Drawing period [s] while no browser is connected (the scene stays current for the next one).
IDLE_DRAW_PERIOD = 0.5
_LEG_SERIES_COLOURS = ('#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b')


@dataclass
class Frame:
    """One picture of the system, built by the node from its latest messages: ``grippers`` ring -> closedness (1
    closed, 0 open, None unknown), ``plot`` (t [s], lengths (N, 6) [m]), ``trails`` ring -> (N, 3) world points,
    ``workspace`` drawn in ring_a's frame and ``master_workspace`` (offset [m] in master_ring_a, scale) placing it on
    the master: a slave position p maps to offset + p / scale."""

    slave: RobotFigure | None = None
    ghost_world_T_b: Pose | None = None
    master: RobotFigure | None = None
    master_handle: Pose | None = None
    grippers: dict[str, float | None] = field(default_factory=dict)
    trails: dict[str, np.ndarray] = field(default_factory=dict)
    panel: str = ''
    plot: tuple[np.ndarray, np.ndarray] | None = None
    workspace: WorkspaceSnapshot | None = None
    master_workspace: tuple[np.ndarray, float] | None = None
    #: the limits felt on the master: an arrow (2, 3) [m, world] from its ring_b
    master_feedback: np.ndarray | None = None
    replay: object | None = None  # a ReplayStatus while a replay runs (the timeline)


def name_input_thread(server: viser.ViserServer) -> None:
    """Name viser's event-loop thread :data:`~rrps_runtime.scheduling.INPUT_THREAD` ``viser``: the
    operator's deadman presses and the link's round trip arrive on it, so the command path's
    scheduling is claimed for it too (rrps_runtime.command_path)."""
    async def named() -> None:
        name_thread(f'{INPUT_THREAD}viser')
    asyncio.run_coroutine_threadsafe(named(), server.get_event_loop()).result(timeout=30.0)


class ViewerServer:
    """The viser server of the viewer: draws :class:`Frame` s and runs the operator controls (ValueError: rate <= 0).

    ``structure``: (vertices, faces) in the world frame, or None; ``rate`` [Hz] of the drawing thread; ``robots``: a
    fleet's robots (empty: one); ``payload_max`` [kg]: the payload slider's top (0: no slider).
    """

    def __init__(self, *, host: str, port: int, control: OperatorControl, actions: OperatorActions,
                 frame_source: Callable[[], Frame], geometry: RobotGeometry,
                 master_geometry: RobotGeometry | None, master_origin: Pose,
                 structure: tuple[np.ndarray, np.ndarray] | None = None, rate: float = 40.0,
                 title: str = 'rrps viewer', robots: Sequence[str] = (), payload_max: float = 0.0):
        if not rate > 0.0:
            raise ValueError(f'rate must be > 0 Hz, got {rate}')
        self.control = control
        self.actions = actions
        self.robots = tuple(robots)
        self.payload_max = float(payload_max)
        self.master_origin = master_origin
        self._frame_source = frame_source
        self._period = 1.0 / rate
        self._lock = threading.Lock()
        self._clients: dict[int, ClientControls] = {}
        self._handle_pose: Pose | None = None
        self._stop = threading.Event()
        self.frames_drawn = 0
        self._workspace_version = -1
        self._workspace_scale = 1.0
        self._drawn_key: tuple | None = None
        self._frame_figures: tuple = ()
        install_shared_encoding()  # a window is encoded once for all browsers
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.server.gui.set_panel_label(title)
        self.server.gui.main_panel.dock_right()   # the 3-D view is the window left of it (first_view)
        self.server.scene.set_up_direction('+z')
        self.server.initial_camera.position = (1.2, -2.0, 1.2)  # framed on the robot once odometry
        self.server.initial_camera.look_at = (0.3, -0.35, 0.4)  # places it (first_view)
        self.first_view = FirstView(self.server, None if structure is None else structure[0],
                                    reach=1.5 * geometry.characteristic_length)
        self.nodes: dict[str, object] = {}
        build_scene(self.server.scene, self.nodes, geometry, master_geometry, structure, master_origin)
        self._build_panel()
        self.server.on_client_connect(self._on_connect)
        self.server.on_client_disconnect(self._on_disconnect)
        self.links = LinkMonitor(self.server)
        name_input_thread(self.server)
        self._thread = threading.Thread(target=self._run, name='viewer-draw', daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The bound port (viser moves to the next free one if ``port`` is taken)."""
        return self.server.get_port()

    # --- scene -------------------------------------------------------------------------------

    def _scene_key(self, frame: Frame) -> tuple:
        """What the 3-D scene of ``frame`` depends on: figures are cached by the node (the same
        object while their inputs are unchanged), the rest compared by value."""
        trails = tuple(len(p) for p in frame.trails.values())
        ghost = None if frame.ghost_world_T_b is None else frame.ghost_world_T_b
        feedback = None if frame.master_feedback is None else frame.master_feedback.tobytes()
        workspace = None if frame.workspace is None else frame.workspace.version
        master_ws = None if frame.master_workspace is None else (
            frame.master_workspace[0].tobytes(), frame.master_workspace[1])
        return (id(frame.slave), id(frame.master), ghost, tuple(frame.grippers.items()), trails,
                feedback, workspace, master_ws)

    def _draw(self, frame: Frame) -> None:
        now = time.monotonic()
        if frame.panel and frame.panel != self._panel.content and now - self._last_panel >= 0.25:
            self._panel.content = frame.panel  # text for people: 4 Hz is plenty
            self._last_panel = now
        with self._lock:
            self._handle_pose = frame.master_handle
            clients = list(self._clients.values())
        for controls in clients:
            controls.recording.show(frame.replay)
        self.first_view.update(frame, self._viser_clients)
        key = self._scene_key(frame)
        if key == self._drawn_key:
            return  # nothing moved: no scene message at all (an idle viewer costs little)
        self._drawn_key = key
        self._frame_figures = (frame.slave, frame.master)  # keeps the ids of the key alive
        n = self.nodes
        with self.server.atomic():
            if frame.slave is not None:
                draw_robot(self.nodes, '/robot', frame.slave)
            if frame.master is not None and '/master/legs' in n:
                draw_robot(self.nodes, '/master', frame.master)
            for ring in ('ring_a', 'ring_b'):
                closed = frame.grippers.get(ring)
                handle = n[f'/robot/grippers/{ring}']
                colour = ((200, 200, 200) if closed is None
                          else (30, 30, 30) if closed >= 0.5 else (250, 220, 60))
                if tuple(handle.color) != colour:
                    handle.color = colour
                points = frame.trails.get(ring)
                trail = n[f'/trail/{ring}']
                if points is not None and len(points) >= 2:
                    segments = np.stack([points[:-1], points[1:]], axis=1).astype(np.float32)
                    if segments.shape != trail.points.shape or not np.array_equal(segments, trail.points):
                        trail.points = segments
                        trail.visible = True
            ghost = n['/ghost/ring_b']
            if frame.ghost_world_T_b is not None:
                ghost.position = frame.ghost_world_T_b.position
                ghost.wxyz = frame.ghost_world_T_b.wxyz
                ghost.visible = True
            else:
                ghost.visible = False
        self._draw_workspace(frame)
        arrow = self.nodes.get('/master/feedback')
        if arrow is not None:
            if frame.master_feedback is not None and np.linalg.norm(
                    frame.master_feedback[1] - frame.master_feedback[0]) > 1e-4:
                arrow.points = frame.master_feedback[None].astype(np.float32)
                arrow.visible = True
            elif arrow.visible:
                arrow.visible = False

    def _draw_workspace(self, frame: Frame) -> None:
        """The reachable set's boundary around the robot (ring_a's frame: it moves with ring_a)
        and, scaled, on the master; point clouds are sent only when a new workspace came."""
        ws = frame.workspace
        if ws is None:
            return
        scene = self.server.scene
        n = self.nodes
        master = frame.master_workspace if '/master/ring_a' in n else None
        if master is not None and '/master/ring_a/workspace' not in n:
            n['/master/ring_a/workspace'] = scene.add_frame('/master/ring_a/workspace',
                                                            show_axes=False)
        if ws.version != self._workspace_version or (
                master is not None and master[1] != self._workspace_scale):
            self._workspace_version = ws.version
            shell = ws.boundary.astype(np.float32).reshape(-1, 3)
            singular = ws.near_singular.astype(np.float32).reshape(-1, 3)
            n['/robot/ring_a/workspace'] = scene.add_point_cloud(
                '/robot/ring_a/workspace', points=shell, colors=(90, 160, 235),
                point_size=0.005, point_shape='circle')
            n['/robot/ring_a/workspace_singular'] = scene.add_point_cloud(
                '/robot/ring_a/workspace_singular', points=singular, colors=(245, 150, 20),
                point_size=0.007, point_shape='circle', visible=len(singular) > 0)
            if master is not None:
                self._workspace_scale = master[1]
                n['/master/ring_a/workspace/shell'] = scene.add_point_cloud(
                    '/master/ring_a/workspace/shell', points=shell / np.float32(master[1]),
                    colors=(90, 160, 235), point_size=0.002, point_shape='circle')
        if master is not None:
            node = n['/master/ring_a/workspace']
            if not np.allclose(node.position, master[0], atol=1e-5):
                node.position = np.asarray(master[0], dtype=float)

    # --- panel -------------------------------------------------------------------------------

    def _build_panel(self) -> None:
        gui = self.server.gui
        with gui.add_folder('Status', order=10):
            self._panel = gui.add_markdown('waiting for the robot…')
        with gui.add_folder('Leg lengths [m]', order=11):
            empty = tuple(np.zeros(1) for _ in range(7))
            self._plot = gui.add_uplot(
                data=empty,
                series=(viser.uplot.Series(label='t [s]'),
                        *(viser.uplot.Series(label=f'leg_{i + 1}', stroke=c, width=1.5)
                          for i, c in enumerate(_LEG_SERIES_COLOURS))),
                scales={'x': viser.uplot.Scale(time=False, auto=True),
                        'y': viser.uplot.Scale(auto=True)},
                legend=viser.uplot.Legend(show=True), aspect=1.6)
        self._last_panel = 0.0

    def _update_plot(self, frame: Frame) -> None:
        if frame.plot is None:  # the frame carries a plot only when it is due (5 Hz)
            return
        t, lengths = frame.plot
        if len(t) < 2:
            return
        self._plot.data = (np.asarray(t, dtype=float),
                           *(np.asarray(lengths[:, i], dtype=float) for i in range(6)))

    # --- clients -----------------------------------------------------------------------------

    def _on_connect(self, client: viser.ClientHandle) -> None:
        self.control.connect(client.client_id)
        controls = ClientControls(self, client)
        with self._lock:
            self._clients[client.client_id] = controls
        self.first_view.show(client)
        self.refresh_all()

    def _viser_clients(self) -> list[viser.ClientHandle]:
        with self._lock:
            return [controls.client for controls in self._clients.values()]

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            controls = self._clients.pop(client.client_id, None)
        if self.control.disconnect(client.client_id) and controls is not None:
            self.actions.master_target(client.client_id, None)
        if not self._stop.is_set():  # when the server stops, every client leaves at once
            self.refresh_all()

    def refresh_all(self) -> None:
        """Bring every client's controls in line with who controls now (control changed)."""
        with self._lock:
            clients = list(self._clients.values())
            handle_pose = self._handle_pose
        for controls in clients:
            try:
                controls.sync(handle_pose)
            except (KeyError, RuntimeError):  # the client left while we updated it
                pass
        with self._lock:
            version = self.control.version
            for controls in clients:
                controls.version_seen = version

    def tell(self, client_id: int, message: str, *, ok: bool) -> None:
        """Show the result of a request to one client (a notification and the last-message line)."""
        with self._lock:
            controls = self._clients.get(client_id)
        if controls is None:
            return
        controls.last_message.content = ('✅ ' if ok else '⛔ ') + message
        controls.client.add_notification('rrps' if ok else 'refused', message,
                                          auto_close_seconds=4.0, color='green' if ok else 'red')

    # --- drawing thread ----------------------------------------------------------------------

    def _run(self) -> None:
        next_time = time.monotonic()
        while not self._stop.is_set():
            try:
                frame = self._frame_source()
                self._draw(frame)
                self._update_plot(frame)
                self.frames_drawn += 1
                with self._lock:
                    stale = any(c.version_seen != self.control.version for c in self._clients.values())
                if stale:
                    self.refresh_all()
            except Exception as exc:  # keep drawing; a bad frame must not kill the viewer
                print(f'rrps viewer: drawing failed: {exc!r}')
            with self._lock:  # nobody looking: keep the scene current at IDLE_DRAW_PERIOD only
                period = self._period if self._clients else max(self._period, IDLE_DRAW_PERIOD)
            next_time += period
            delay = next_time - time.monotonic()
            if delay < -period:
                next_time = time.monotonic()
            self._stop.wait(max(delay, 0.0))

    def stop(self) -> None:
        """Stop drawing and close the server (frees the port)."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.links.stop()
        self.server.stop()
