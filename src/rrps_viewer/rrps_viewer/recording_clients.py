"""The viewer node's recording side: the flight recorder's "Save last 60 s" and the replay's timeline.

:meth:`ViewerRecording.save` calls ``flight_recorder/save`` and sends the file to the browser once it exists (the
recorder shares the viewer's file system); ``replay/status`` is kept while heard in the last 3 s;
:meth:`ViewerRecording.control` sets the replay's parameters. Runs on the executor's thread.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from std_srvs.srv import Trigger

from rrps_interfaces.recording import FLIGHT_RECORDER_SAVE, REPLAY_STATUS, ReplayStatus
from rrps_interfaces.status import ContractError
from rrps_runtime.qos import STATE_QOS

__all__ = ['ViewerRecording', 'REPLAY_PARAMETERS']

#: The replay node's standard parameter service, relative to the viewer's namespace.
REPLAY_PARAMETERS = 'replay_node/set_parameters'
_FRESH = 3.0
_DOWNLOAD_TIMEOUT = 60.0


class ViewerRecording:
    """See the module docstring. ``tell(client_id, message, ok=)`` reports to one browser;
    ``send_file(client_id, filename, content)`` offers a download (False if it left)."""

    def __init__(self, node, *, tell, send_file):
        self._node = node
        self._tell = tell
        self._send_file = send_file
        self._save_client = node.create_client(Trigger, FLIGHT_RECORDER_SAVE)
        self._replay_client = node.create_client(SetParameters, REPLAY_PARAMETERS)
        self._lock = threading.Lock()
        self._status: tuple[float, ReplayStatus] | None = None
        self._downloads: list[tuple[int, Path, float]] = []
        node.create_subscription(DiagnosticStatus, REPLAY_STATUS, self._on_status, STATE_QOS)

    def _on_status(self, msg: DiagnosticStatus) -> None:
        try:
            status = ReplayStatus.from_key_values(msg.values)
        except ContractError as exc:
            self._node.get_logger().warning(f'replay/status unreadable: {exc}',
                                            throttle_duration_sec=10.0)
            return
        with self._lock:
            self._status = (time.monotonic(), status)

    def replay_status(self) -> ReplayStatus | None:
        """The replay's status while one runs (heard in the last 3 s), else None."""
        with self._lock:
            if self._status is None or time.monotonic() - self._status[0] > _FRESH:
                return None
            return self._status[1]

    def handle(self, client_id: int, request: tuple) -> None:
        """A queued browser request: ('save',) or ('replay', {parameter: value})."""
        if request[0] == 'save':
            self.save(client_id)
        else:
            self.control(client_id, **request[1])

    def save(self, client_id: int) -> None:
        if not self._save_client.service_is_ready():
            self._tell(client_id, f'save: service {self._save_client.srv_name} is not available '
                                  '(no flight recorder running)', ok=False)
            return
        future = self._save_client.call_async(Trigger.Request())

        def done(fut) -> None:
            response = fut.result()
            if response is None or not response.success:
                self._tell(client_id, 'save refused: '
                           + (response.message if response is not None else 'no response'),
                           ok=False)
                return
            with self._lock:
                self._downloads.append((client_id, Path(response.message),
                                        time.monotonic() + _DOWNLOAD_TIMEOUT))
            self._tell(client_id, f'flight recorder writing {response.message}', ok=True)
        future.add_done_callback(done)

    def poll(self) -> None:
        """Send the files that are written (called by the viewer's timer)."""
        with self._lock:
            pending, self._downloads = self._downloads, []
        keep = []
        for client_id, path, deadline in pending:
            if path.is_file():
                try:
                    content = path.read_bytes()
                except OSError as exc:
                    self._tell(client_id, f'cannot read {path}: {exc}', ok=False)
                    continue
                if self._send_file(client_id, path.name, content):
                    self._tell(client_id, f'saved {path} ({len(content) / 1e6:.1f} MB): '
                                          'download offered', ok=True)
            elif time.monotonic() > deadline:
                self._tell(client_id, f'{path} was not written in time', ok=False)
            else:
                keep.append((client_id, path, deadline))
        with self._lock:
            self._downloads = keep + self._downloads

    def control(self, client_id: int, **changes) -> None:
        """Set the replay's ``seek`` [s], ``paused`` or ``rate``."""
        if not self._replay_client.service_is_ready():
            self._tell(client_id, 'replay: no replay node is running', ok=False)
            return
        parameters = []
        for name, value in changes.items():
            if isinstance(value, bool):
                v = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
            else:
                v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
            parameters.append(Parameter(name=name, value=v))
        future = self._replay_client.call_async(SetParameters.Request(parameters=parameters))

        def done(fut) -> None:
            response = fut.result()
            failed = [r.reason for r in (response.results if response else []) if not r.successful]
            if response is None or failed:
                self._tell(client_id, 'replay refused: ' + ('; '.join(failed) or 'no response'),
                           ok=False)
        future.add_done_callback(done)
