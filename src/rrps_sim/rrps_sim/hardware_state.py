"""The simulated robot's physical state on disk (JSON, written atomically), so that a restarted
driver resumes it, as a real robot stays where it is (docs/deployment.md, 'Activation after a
restart'). :func:`load_state` returns None when there is no file yet. Pure Python, no ROS import.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.names import RINGS

__all__ = ['HardwareState', 'StateFileError', 'StateFileWriter', 'save_state', 'load_state']

FORMAT = 1


class StateFileError(ValueError):
    """A state file that cannot be trusted: unreadable, of another robot, or out of range."""


@dataclass(frozen=True)
class HardwareState:
    """Leg lengths [m], extra-DOF ring angles [rad] and gripper closedness of one robot."""

    robot: str
    lengths: tuple[float, ...]
    rings: tuple[float, ...] = ()
    grippers: dict = field(default_factory=lambda: {ring: True for ring in RINGS})


def save_state(path: str | Path, state: HardwareState) -> None:
    """Write ``state`` to ``path`` atomically (a temporary file renamed over it; not fsynced:
    a killed process is covered, a power cut of the simulating machine is not)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {'format': FORMAT, 'robot': state.robot, 'lengths': [float(v) for v in state.lengths],
            'rings': [float(v) for v in state.rings],
            'grippers': {ring: bool(state.grippers[ring]) for ring in RINGS}}
    fd, tmp = tempfile.mkstemp(prefix=f'.{path.name}.', dir=path.parent)
    try:
        with os.fdopen(fd, 'w') as f:
            json.dump(data, f)
        os.replace(tmp, path)  # atomic: a killed driver leaves the old file or the new one
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_state(path: str | Path, geometry: RobotGeometry, n_rings: int = 0) -> HardwareState | None:
    """The state saved at ``path`` for ``geometry`` (None when there is no file).

    StateFileError when the file is unreadable, belongs to another robot, or holds lengths
    outside the stroke, ring angles outside their range or both grippers open.
    """
    path = Path(path)
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text())
        robot = str(data['robot'])
        lengths = tuple(float(v) for v in data['lengths'])
        rings = tuple(float(v) for v in data.get('rings', ()))
        grippers = {ring: bool(data['grippers'][ring]) for ring in RINGS}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise StateFileError(f'{path}: unreadable robot state ({exc})') from None
    g = geometry
    if robot != g.name:
        raise StateFileError(f'{path}: the state of robot {robot!r}, not {g.name!r}')
    if len(lengths) != 6 or not all(math.isfinite(v) for v in lengths) \
            or np.any(np.array(lengths) < g.min_length) or np.any(np.array(lengths) > g.max_length):
        raise StateFileError(f'{path}: leg lengths {lengths} outside the stroke '
                             f'[{g.min_length}, {g.max_length}] m')
    if len(rings) != n_rings or not all(math.isfinite(v) for v in rings):
        raise StateFileError(f'{path}: {len(rings)} ring angles, the robot has {n_rings}')
    if not any(grippers.values()):
        raise StateFileError(f'{path}: both grippers open')
    return HardwareState(robot=robot, lengths=lengths, rings=rings, grippers=grippers)


class StateFileWriter:
    """Writes the newest submitted :class:`HardwareState` to ``path`` from a thread of its own.

    :meth:`submit` never blocks on the file system: it replaces a state not yet written (the
    file only ever needs the newest). ``error`` holds the last write's failure (None after a
    successful write), ``written`` counts the states on disk.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.error: OSError | None = None
        self.written = 0
        self._pending: HardwareState | None = None
        self._busy = False
        self._closed = False
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._run, name='state-file-writer', daemon=True)
        self._thread.start()

    def submit(self, state: HardwareState) -> None:
        """Queue ``state`` for writing (replacing one not yet written)."""
        with self._cond:
            if self._closed:
                raise RuntimeError('the state file writer is closed')
            self._pending = state
            self._cond.notify_all()

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every submitted state is written (or failed); False on timeout."""
        with self._cond:
            return self._cond.wait_for(lambda: self._pending is None and not self._busy, timeout)

    def close(self, timeout: float | None = None) -> bool:
        """Write what is pending, then stop the thread; False when it did not finish in time."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def _run(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._pending is not None or self._closed)
                state, self._pending = self._pending, None
                if state is None:  # closed, nothing left
                    return
                self._busy = True
            try:
                save_state(self.path, state)
                error = None
            except OSError as exc:
                error = exc
            with self._cond:
                self._busy = False
                self.error = error
                self.written += error is None
                self._cond.notify_all()
