"""The viser rendering layer: scene nodes, the status panel and the per-browser operator controls.

Scene names (all in the ``world`` frame, REP-103, z up):
``/structure`` (the climbed member), ``/robot/ring_a`` and ``/robot/ring_b`` (ring frames),
``/robot/legs`` (six leg segments coloured by margin), ``/robot/grippers/ring_a|ring_b``
(closed = solid, open = faint), ``/ghost/ring_b`` (the commanded ring_b pose, translucent),
``/master/...`` (the master robot on its console), ``/trail/ring_a|ring_b`` (world paths).
Each connected browser also gets its own ``/operator/master_handle`` gizmo while it holds control.

Drawing runs in this module's own thread at ``rate`` Hz, whatever the control rate; the
node only hands over a :class:`Frame` through ``frame_source``. Quaternions are converted to
viser's (w, x, y, z) by :attr:`Pose.wxyz` only.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np
import viser
import viser.uplot

from rrps_kinematics.geometry import RobotGeometry

from ._control import ControlResult, OperatorControl
from ._recording import RecordingControls
from rrps_kinematics.pose import Pose

from ._scene import RobotFigure, torus_mesh

__all__ = ['Frame', 'OperatorActions', 'ViewerServer', 'TELEOP_MODES', 'ROTATION_MODES']

TELEOP_MODES = ('cartesian', 'joint')
ROTATION_MODES = ('relative', 'absolute')

_LEG_SERIES_COLOURS = ('#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b')


class OperatorActions(Protocol):
    """What the controls ask of the robot; called only for the client holding control.

    Each returns nothing at once; results come back through :meth:`ViewerServer.tell`.
    """

    def step(self, client_id: int, direction: str) -> None: ...

    def set_gripper(self, client_id: int, ring: str, close: bool) -> None: ...

    def set_mapping(self, client_id: int, mode: str, rotation_mode: str, scale: float) -> None: ...

    def master_target(self, client_id: int, world_T_handle: Pose | None) -> None: ...


@dataclass
class Frame:
    """One picture of the system, built by the node from its latest messages.

    ``grippers`` maps ring name to closedness (1 closed, 0 open, None unknown). ``plot`` is
    (t [s], lengths (N, 6) [m]). ``trails`` maps ring name to (N, 3) world points.
    ``master_handle`` is where the master's ring_b is in the world (the gizmo's start pose).
    """

    slave: RobotFigure | None = None
    ghost_world_T_b: Pose | None = None
    master: RobotFigure | None = None
    master_handle: Pose | None = None
    grippers: dict[str, float | None] = field(default_factory=dict)
    trails: dict[str, np.ndarray] = field(default_factory=dict)
    panel: str = ''
    plot: tuple[np.ndarray, np.ndarray] | None = None
    replay: object | None = None  # a ReplayStatus while a replay runs (the timeline)


class _ClientControls:
    """The operator folder of one browser: token entry, control, teleop, climb, grippers."""

    def __init__(self, server: 'ViewerServer', client: viser.ClientHandle):
        self.server = server
        self.client = client
        self.client_id = client.client_id
        self.gizmo = None
        self.version_seen = -1
        gui = client.gui
        control = server.control
        cid = self.client_id
        with gui.add_folder('Operator', order=0):
            self.role = gui.add_markdown('**Read-only viewer.** Enter the operator token to drive.')
            self.token = gui.add_text('Token', '', hint='the operator token printed at start-up')
            self.enter = gui.add_button('Enter token', icon=viser.Icon.KEY)
            self.take = gui.add_button('Take control', icon=viser.Icon.STEERING_WHEEL)
            self.release = gui.add_button('Release control', color='gray')
            self.hand_to = gui.add_dropdown('Hand over to', ('—',))
            self.hand = gui.add_button('Hand over')
        with gui.add_folder('Teleoperation', order=1):
            self.clutch = gui.add_checkbox('Engage (clutch)', False,
                                           hint='unchecked = clutch out: move the master freely')
            self.deadman = gui.add_button('Hold to move (deadman)', color='green',
                                          hint='press and hold: teleop/enable is sent while held')
            self.mode = gui.add_dropdown('Mapping mode', TELEOP_MODES)
            self.rotation = gui.add_dropdown('Rotation', ROTATION_MODES)
            self.scale = gui.add_slider('Translation scale', min=0.5, max=8.0, step=0.5,
                                        initial_value=4.0)
            self.apply = gui.add_button('Apply mapping')
        with gui.add_folder('Climb and grippers', order=2):
            self.step_up = gui.add_button('Climb one step up', icon=viser.Icon.ARROW_UP)
            self.step_down = gui.add_button('Climb one step down', icon=viser.Icon.ARROW_DOWN)
            self.grip_buttons = {}
            for ring in ('ring_a', 'ring_b'):
                self.grip_buttons[(ring, True)] = gui.add_button(f'Close {ring}')
                self.grip_buttons[(ring, False)] = gui.add_button(f'Open {ring}', color='orange')
        self.last_message = gui.add_markdown('', order=3)
        self.recording = RecordingControls(  # "Save last 60 s" and the replay timeline
            client, server.actions, may_control=control.may_control,
            refused=lambda c: server.tell(c, 'read-only: you do not have control', ok=False))

        def guarded(fn: Callable[[], ControlResult | None]):
            def callback(event) -> None:
                if event.client_id != cid:
                    return
                result = fn()
                if result is not None:
                    server.tell(cid, result.message, ok=result.ok)
                server.refresh_all()
            return callback

        def controller_only(fn: Callable[[], None]):
            def callback(event) -> None:
                if event.client_id != cid:
                    return
                if not control.may_control(cid):
                    server.tell(cid, 'read-only: you do not have control', ok=False)
                    return
                fn()
            return callback

        self.enter.on_click(guarded(lambda: control.authenticate(cid, self.token.value)))
        self.take.on_click(guarded(lambda: control.take_control(cid)))
        self.release.on_click(guarded(lambda: control.release(cid)))
        self.hand.on_click(guarded(lambda: self._hand_over()))
        self.clutch.on_update(guarded(lambda: self._clutch()))
        async def on_hold(event) -> None:  # on viser's event loop: no thread-pool delay
            if event.client_id == cid:
                control.hold(cid)

        self.deadman.on_hold(on_hold, callback_hz=20.0)
        actions = server.actions
        self.apply.on_click(controller_only(lambda: actions.set_mapping(
            cid, str(self.mode.value), str(self.rotation.value), float(self.scale.value))))
        self.step_up.on_click(controller_only(lambda: actions.step(cid, 'up')))
        self.step_down.on_click(controller_only(lambda: actions.step(cid, 'down')))
        for (ring, close), button in self.grip_buttons.items():
            button.on_click(controller_only(
                lambda ring=ring, close=close: actions.set_gripper(cid, ring, close)))

    def _hand_over(self) -> ControlResult:
        text = str(self.hand_to.value)
        if not text.startswith('operator '):
            return ControlResult(False, 'choose an operator who entered the token')
        return self.server.control.hand_over(self.client_id, int(text.split()[1]))

    def _clutch(self) -> ControlResult | None:
        control = self.server.control
        if not control.may_control(self.client_id):
            if self.clutch.value:
                self.clutch.value = False
                return ControlResult(False, 'read-only: you do not have control')
            return None
        return control.set_clutch(self.client_id, bool(self.clutch.value))

    def sync(self, handle_pose: Pose | None) -> None:
        """Match the controls to this client's role (called when control changes)."""
        control = self.server.control
        role = control.role(self.client_id)
        controlling = role == 'controller'
        holder = control.controller
        if controlling:
            text = f'**You have control** (operator {self.client_id}).'
        elif role == 'operator':
            text = (f'Token accepted (operator {self.client_id}). '
                    + ('Control is free: take it.' if holder is None
                       else f'Operator {holder} has control.'))
        else:
            text = '**Read-only viewer.** Enter the operator token to drive.'
        self.role.content = text
        self.take.disabled = role != 'operator' or holder is not None
        self.release.disabled = not controlling
        others = [f'operator {c}' for c in control.authenticated_clients() if c != self.client_id]
        self.hand_to.options = tuple(others) if others else ('—',)
        self.hand.disabled = not (controlling and others)
        for handle in (self.clutch, self.deadman, self.mode, self.rotation, self.scale, self.apply,
                       self.step_up, self.step_down, *self.grip_buttons.values()):
            handle.disabled = not controlling
        if not controlling and self.clutch.value:
            self.clutch.value = False
        self.recording.sync(controlling)
        if controlling and self.gizmo is None:
            self._add_gizmo(handle_pose)
        elif not controlling and self.gizmo is not None:
            self.gizmo.remove()
            self.gizmo = None
            self.server.actions.master_target(self.client_id, None)

    def _add_gizmo(self, handle_pose: Pose | None) -> None:
        pose = handle_pose or self.server.master_origin
        gizmo = self.client.scene.add_transform_controls(
            '/operator/master_handle', scale=0.12, depth_test=False,
            position=pose.position, wxyz=pose.wxyz)
        cid = self.client_id
        control = self.server.control
        actions = self.server.actions

        @gizmo.on_update
        def _(event) -> None:
            if event.client_id != cid or not control.may_control(cid):
                return
            if event.phase == 'start':
                control.set_dragging(cid, True)
            elif event.phase == 'end':
                control.set_dragging(cid, False)
            wxyz = np.asarray(event.target.wxyz, dtype=float)
            actions.master_target(cid, Pose(np.asarray(event.target.position, dtype=float),
                                            np.array([wxyz[1], wxyz[2], wxyz[3], wxyz[0]])))

        self.gizmo = gizmo


class ViewerServer:
    """The viser server of the viewer: draws :class:`Frame` s and runs the operator controls.

    Keyword-only: ``host``/``port`` to bind, ``control`` (an :class:`OperatorControl`),
    ``actions`` (an :class:`OperatorActions`), ``frame_source`` (returns the latest Frame),
    ``geometry`` and ``master_geometry`` (ring sizes), ``master_origin`` (world pose of the
    master's ring_a on its console), ``structure`` (a callable adding the climbed member to a
    viser scene, or None), ``rate`` [Hz] of the drawing thread.
    """

    def __init__(self, *, host: str, port: int, control: OperatorControl, actions: OperatorActions,
                 frame_source: Callable[[], Frame], geometry: RobotGeometry,
                 master_geometry: RobotGeometry | None, master_origin: Pose,
                 structure: Callable[[viser.SceneApi], None] | None = None, rate: float = 40.0,
                 title: str = 'rrps viewer'):
        if not rate > 0.0:
            raise ValueError(f'rate must be > 0 Hz, got {rate}')
        self.control = control
        self.actions = actions
        self.master_origin = master_origin
        self._frame_source = frame_source
        self._period = 1.0 / rate
        self._lock = threading.Lock()
        self._clients: dict[int, _ClientControls] = {}
        self._handle_pose: Pose | None = None
        self._stop = threading.Event()
        self.frames_drawn = 0
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.server.gui.set_panel_label(title)
        self.server.scene.set_up_direction('+z')
        self.server.initial_camera.position = (1.2, -2.0, 1.2)
        self.server.initial_camera.look_at = (0.3, -0.35, 0.4)  # robot left of the panel
        self.nodes: dict[str, object] = {}
        self._build_scene(geometry, master_geometry, structure)
        self._build_panel()
        self.server.on_client_connect(self._on_connect)
        self.server.on_client_disconnect(self._on_disconnect)
        self._thread = threading.Thread(target=self._run, name='viewer-draw', daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The bound port (viser moves to the next free one if ``port`` is taken)."""
        return self.server.get_port()

    # --- scene -------------------------------------------------------------------------------

    def _ring_mesh(self, geometry: RobotGeometry, anchors: np.ndarray):
        radius = float(np.mean(np.linalg.norm(anchors[:, :2], axis=1)))
        return torus_mesh(radius=radius, tube=max(0.08 * radius, 1e-3))

    def _build_scene(self, geometry, master_geometry, structure) -> None:
        scene = self.server.scene
        n = self.nodes
        if structure is not None:
            structure(scene)
        n['/grid'] = scene.add_grid('/grid', width=4.0, height=4.0, cell_size=0.25,
                                    plane='xy', position=(0.0, 0.0, 0.0))
        self._add_robot('/robot', geometry, (120, 130, 150), opacity=None)
        n['/ghost/ring_b'] = scene.add_mesh_simple(
            '/ghost/ring_b', *self._ring_mesh(geometry, geometry.ring_b_anchors),
            color=(90, 170, 255), opacity=0.35, visible=False)
        for ring, colour in (('ring_a', (230, 120, 20)), ('ring_b', (20, 140, 230))):
            n[f'/trail/{ring}'] = scene.add_line_segments(
                f'/trail/{ring}', points=np.zeros((1, 2, 3)), colors=colour, thickness=0.006,
                visible=False)
        if master_geometry is not None:
            self._add_robot('/master', master_geometry, (160, 160, 160), opacity=None)
            n['/master/label'] = scene.add_label('/master/label', 'master robot',
                                                 position=self.master_origin.position + [0, 0, 0.2])
        n['/robot/label'] = scene.add_label('/robot/ring_b/label', 'ring_b', position=(0, 0, 0.05))

    def _add_robot(self, prefix: str, geometry: RobotGeometry, colour, *, opacity) -> None:
        scene = self.server.scene
        n = self.nodes
        for ring, anchors in (('ring_a', geometry.ring_a_anchors),
                              ('ring_b', geometry.ring_b_anchors)):
            radius = float(np.mean(np.linalg.norm(anchors[:, :2], axis=1)))
            n[f'{prefix}/{ring}'] = scene.add_frame(f'{prefix}/{ring}', axes_length=0.4 * radius,
                                                    axes_radius=0.02 * radius)
            n[f'{prefix}/{ring}/body'] = scene.add_mesh_simple(
                f'{prefix}/{ring}/body', *self._ring_mesh(geometry, anchors), color=colour,
                opacity=opacity)
            if prefix == '/robot':
                n[f'{prefix}/grippers/{ring}'] = scene.add_mesh_simple(
                    f'{prefix}/{ring}/gripper', *torus_mesh(radius=0.45 * radius,
                                                            tube=0.06 * radius),
                    color=(200, 200, 200))
        thickness = 2.0 * max(geometry.leg_radius, 0.004 * geometry.characteristic_length)
        n[f'{prefix}/legs'] = scene.add_line_segments(
            f'{prefix}/legs', points=np.zeros((6, 2, 3)), colors=(40, 170, 70), thickness=thickness)

    def _draw_robot(self, prefix: str, figure: RobotFigure) -> None:
        n = self.nodes
        for ring, pose in (('ring_a', figure.world_T_a), ('ring_b', figure.world_T_b)):
            n[f'{prefix}/{ring}'].position = pose.position
            n[f'{prefix}/{ring}'].wxyz = pose.wxyz
        legs = n[f'{prefix}/legs']
        points = figure.leg_points.astype(np.float32)
        if not np.array_equal(points, legs.points):  # arrays are not de-duplicated by viser
            legs.points = points
        colours = np.repeat(figure.leg_colours[:, None, :], 2, axis=1)
        if not np.array_equal(colours, legs.colors):
            legs.colors = colours

    def _draw(self, frame: Frame) -> None:
        n = self.nodes
        with self.server.atomic():
            if frame.slave is not None:
                self._draw_robot('/robot', frame.slave)
            if frame.master is not None and '/master/legs' in n:
                self._draw_robot('/master', frame.master)
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
        now = time.monotonic()
        if frame.panel and frame.panel != self._panel.content and now - self._last_panel >= 0.25:
            self._panel.content = frame.panel  # text for people: 4 Hz is plenty
            self._last_panel = now
        with self._lock:
            self._handle_pose = frame.master_handle
            clients = list(self._clients.values())
        for controls in clients:
            controls.recording.show(frame.replay)

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
        self._last_plot = 0.0
        self._last_panel = 0.0

    def _update_plot(self, frame: Frame, now: float) -> None:
        if frame.plot is None or now - self._last_plot < 0.2:
            return
        t, lengths = frame.plot
        if len(t) < 2:
            return
        self._last_plot = now
        self._plot.data = (np.asarray(t, dtype=float),
                           *(np.asarray(lengths[:, i], dtype=float) for i in range(6)))

    # --- clients -----------------------------------------------------------------------------

    def _on_connect(self, client: viser.ClientHandle) -> None:
        self.control.connect(client.client_id)
        controls = _ClientControls(self, client)
        with self._lock:
            self._clients[client.client_id] = controls
        self.refresh_all()

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
            now = time.monotonic()
            try:
                frame = self._frame_source()
                self._draw(frame)
                self._update_plot(frame, now)
                self.frames_drawn += 1
                with self._lock:
                    stale = any(c.version_seen != self.control.version for c in self._clients.values())
                if stale:
                    self.refresh_all()
            except Exception as exc:  # keep drawing; a bad frame must not kill the viewer
                print(f'rrps viewer: drawing failed: {exc!r}')
            next_time += self._period
            delay = next_time - time.monotonic()
            if delay < -self._period:
                next_time = time.monotonic()
            self._stop.wait(max(delay, 0.0))

    def stop(self) -> None:
        """Stop drawing and close the server (frees the port)."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.server.stop()
