"""The viewer's recording controls (viser): "Save last 60 s" and the replay timeline (seek, pause, rate).

Only the widgets; the node side is :class:`rrps_viewer.recording_clients.ViewerRecording`.
"""

from __future__ import annotations

import time
from typing import Protocol

import viser

from rrps_interfaces.recording import ReplayStatus

__all__ = ['RecordingActions', 'RecordingControls', 'send_file', 'REPLAY_RATES']

REPLAY_RATES = ('0.25', '0.5', '1', '2', '4', '8')


class RecordingActions(Protocol):
    """What the recording controls ask of the node (only for the client holding control)."""

    def save_flight_recording(self, client_id: int) -> None: ...

    def replay_control(self, client_id: int, **changes) -> None: ...


def send_file(server: viser.ViserServer, client_id: int, filename: str, content: bytes) -> bool:
    """Offer ``content`` to one browser as a download; False if it left."""
    client = server.get_clients().get(client_id)
    if client is None:
        return False
    client.send_file_download(filename, content)
    return True


class RecordingControls:
    """The "Recording" folder of one browser."""

    def __init__(self, client: viser.ClientHandle, actions: RecordingActions, *,
                 may_control, refused, order: int = 4):
        self.client_id = client.client_id
        gui = client.gui
        cid = self.client_id
        with gui.add_folder('Recording', order=order):
            self.save = gui.add_button(
                'Save last 60 s', icon=viser.Icon.DEVICE_FLOPPY,
                hint='write the flight recorder (the last 60 s of every topic) and download it')
            self.timeline = gui.add_slider('Replay time [s]', min=0.0, max=1.0, step=0.05,
                                           initial_value=0.0, visible=False)
            self.paused = gui.add_checkbox('Replay paused', False, visible=False)
            self.rate = gui.add_dropdown('Replay rate', REPLAY_RATES, initial_value='1',
                                         visible=False)
            self.info = gui.add_markdown('', visible=False)
        self._shown: ReplayStatus | None = None
        self._last_show = 0.0

        def controller_only(fn):
            def callback(event) -> None:
                if event.client_id != cid:  # another browser, or set by the program
                    return
                if not may_control(cid):
                    refused(cid)
                    return
                fn()
            return callback

        self.save.on_click(controller_only(lambda: actions.save_flight_recording(cid)))
        self.timeline.on_update(controller_only(
            lambda: actions.replay_control(cid, seek=float(self.timeline.value))))
        self.paused.on_update(controller_only(
            lambda: actions.replay_control(cid, paused=bool(self.paused.value))))
        self.rate.on_update(controller_only(
            lambda: actions.replay_control(cid, rate=float(self.rate.value))))

    def sync(self, controlling: bool) -> None:
        """Enable the controls for the operator holding control only."""
        for handle in (self.save, self.timeline, self.paused, self.rate):
            handle.disabled = not controlling

    def show(self, status: ReplayStatus | None) -> None:
        """Show the replay's timeline (or hide it when no replay runs); at most 4 Hz."""
        now = time.monotonic()
        if status == self._shown or (status is not None and self._shown is not None
                                     and now - self._last_show < 0.25):
            return
        self._last_show = now
        visible = status is not None
        for handle in (self.timeline, self.paused, self.rate, self.info):
            if handle.visible != visible:
                handle.visible = visible
        self._shown = status
        if status is None:
            return
        duration = max(status.duration, 0.05)
        if self.timeline.max != duration:
            self.timeline.max = duration
        self.timeline.value = min(max(status.time, 0.0), duration)
        self.paused.value = status.paused
        rate = f'{status.rate:g}'
        if rate in REPLAY_RATES:
            self.rate.value = rate
        state = 'finished' if status.finished else 'paused' if status.paused else 'playing'
        self.info.content = (f'**Replay** {state}: {status.time:.1f} / {status.duration:.1f} s '
                             f'at {status.rate:g}x' + (
                                 f'; commands under replay/ ({len(status.remapped)})'
                                 if status.remapped else ''))
