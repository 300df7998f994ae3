"""The operator controls of one browser (viser GUI): what a person clicks to drive the robot (docs/viewer.md).

Each browser gets a :class:`ClientControls`; requests go to an :class:`OperatorActions` (the viewer node), which
answers later through ``ViewerServer.tell``."""

from __future__ import annotations

from typing import Callable, Protocol

import numpy as np
import viser

from rrps_description.pose import Pose
from rrps_teleop.mapping import MODES, ROTATION_MODES
from rrps_viewer._control import ControlResult
from rrps_viewer._recording import RecordingControls

__all__ = ['ClientControls', 'OperatorActions']


class OperatorActions(Protocol):
    """What the controls ask of the robot; called only for the client holding control.

    Each returns nothing at once; results come back through :meth:`ViewerServer.tell`.
    """

    def step(self, client_id: int, direction: str) -> None: ...

    def set_gripper(self, client_id: int, ring: str, close: bool) -> None: ...

    def set_mapping(self, client_id: int, mode: str, rotation_mode: str, scale: float) -> None: ...

    def master_target(self, client_id: int, world_T_handle: Pose | None) -> None: ...

    def set_driver_active(self, client_id: int, active: bool) -> None: ...

    def resume_climb(self, client_id: int) -> None: ...

    def select_robot(self, client_id: int, name: str) -> None: ...

    def set_workspace_payload(self, client_id: int, mass: float) -> None: ...


class ClientControls:
    """The operator folder of one browser: token entry, control, teleop, climb, grippers.

    ``server`` is the :class:`ViewerServer` (its ``control``, ``actions``, ``master_origin``,
    ``tell`` and ``refresh_all``)."""

    def __init__(self, server, client: viser.ClientHandle):
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
            self.mode = gui.add_dropdown('Mapping mode', MODES)
            self.rotation = gui.add_dropdown('Rotation', ROTATION_MODES)
            self.scale = gui.add_slider('Translation scale', min=0.5, max=8.0, step=0.5,
                                        initial_value=4.0)
            self.apply = gui.add_button('Apply mapping')
            self.payload = self._payload_slider(gui)
        with gui.add_folder('Robot', order=2):
            self.robot = self.drive = None
            if server.robots:  # a fleet: which robot the master drives
                self.robot = gui.add_dropdown('Robot', tuple(server.robots))
                self.drive = gui.add_button('Drive this robot', icon=viser.Icon.STEERING_WHEEL,
                                            hint='the master drives one robot at a time; the others hold. '
                                                 'Engage the clutch and press the deadman again after a switch')
            self.activate = gui.add_button('Activate driver', icon=viser.Icon.PLAYER_PLAY,
                                           hint='the driver starts (and restarts) inactive: '
                                                'nothing moves until it is activated')
            self.deactivate = gui.add_button('Deactivate driver', color='gray',
                                             icon=viser.Icon.PLAYER_PAUSE)
            self.step_up = gui.add_button('Climb one step up', icon=viser.Icon.ARROW_UP)
            self.step_down = gui.add_button('Climb one step down', icon=viser.Icon.ARROW_DOWN)
            self.resume = gui.add_button('Resume climb', icon=viser.Icon.PLAYER_TRACK_NEXT,
                                         hint='a paused climb (lost link or state) waits for this')
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
        self.activate.on_click(controller_only(lambda: actions.set_driver_active(cid, True)))
        self.deactivate.on_click(controller_only(lambda: actions.set_driver_active(cid, False)))
        self.resume.on_click(controller_only(lambda: actions.resume_climb(cid)))
        self._wire_payload(controller_only)
        if self.drive is not None:
            self.drive.on_click(controller_only(lambda: actions.select_robot(cid, str(self.robot.value))))
        self.step_up.on_click(controller_only(lambda: actions.step(cid, 'up')))
        self.step_down.on_click(controller_only(lambda: actions.step(cid, 'down')))
        for (ring, close), button in self.grip_buttons.items():
            button.on_click(controller_only(
                lambda ring=ring, close=close: actions.set_gripper(cid, ring, close)))

    def _payload_slider(self, gui):
        """The slider of the payload [kg] on ring_b of the drawn load-feasible workspace (None
        when the viewer has none)."""
        top = self.server.payload_max
        if not top > 0.0:
            return None
        return gui.add_slider('Payload [kg]', min=0.0, max=top, step=top / 50.0, initial_value=0.0,
                              hint='a payload on ring_b: the workspace drawn is where the robot also holds it '
                                   '(actuator forces, gripper holding)')

    def _wire_payload(self, controller_only) -> None:
        if self.payload is not None:
            self.payload.on_update(controller_only(
                lambda: self.server.actions.set_workspace_payload(self.client_id, float(self.payload.value))))

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
                       self.activate, self.deactivate, self.step_up, self.step_down, self.resume,
                       *self.grip_buttons.values(),
                       *(h for h in (self.robot, self.drive, self.payload) if h is not None)):
            handle.disabled = not controlling
        if self.clutch.value and not (controlling and control.clutch_engaged):
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
