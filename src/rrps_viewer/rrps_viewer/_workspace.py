"""The slave's reachable workspace for the viewer (§3.1), kept up to date off the drawing thread (no rclpy, no viser).

:class:`WorkspaceView` recomputes :func:`rrps_kinematics.workspace.reachable_workspace` in a worker thread when the
orientation, ring_a's attitude (by ``angle_step``) or the payload changed, restricts it to the load-feasible positions
(:func:`rrps_loads.load_workspace.load_workspace`) and keeps the boundary, which is drawn.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from rrps_description.geometry import RobotGeometry
from rrps_description.loads import Payload
from rrps_description.rotations import rotation_angle_between
from rrps_kinematics.workspace import (
    NEAR_SINGULAR,
    UNREACHABLE,
    Workspace,
    distance_to_boundary,
    reachable_workspace,
)
from rrps_loads.load_workspace import load_workspace

__all__ = ['WorkspaceSnapshot', 'WorkspaceView', 'boundary_points']


def boundary_points(ws: Workspace) -> tuple[np.ndarray, np.ndarray]:
    """(reachable points with an unreachable face neighbour (N, 3), the near-singular ones among
    all reachable points (M, 3)), positions of ring_b in ring_a [m]."""
    inside = ws.labels != UNREACHABLE
    shell = inside & ~ndimage.binary_erosion(inside, border_value=0)
    return (ws.origin + ws.spacing * np.argwhere(shell),
            ws.origin + ws.spacing * np.argwhere(ws.labels == NEAR_SINGULAR))


@dataclass(frozen=True)
class WorkspaceSnapshot:
    """One computed workspace: at orientation ``quaternion_xyzw`` with ring_a at ``world_q_a``,
    the load-feasible set under ``payload`` [kg] (``workspace``), its boundary and near-singular
    points (ring_a frame), the reachable volume without loads [m^3] and how long it took [s]."""

    quaternion_xyzw: np.ndarray
    workspace: Workspace
    boundary: np.ndarray
    near_singular: np.ndarray
    seconds: float
    version: int
    world_q_a: np.ndarray | tuple = (0.0, 0.0, 0.0, 1.0)
    payload: float = 0.0
    reachable_volume: float = 0.0

    def distance(self, position) -> float:
        """Distance [m] from ring_b's position to the boundary (positive inside)."""
        return float(distance_to_boundary(self.workspace, position))

    def describe(self, position) -> str:
        """The panel's line: the volume (load-feasible of reachable) and ring_b's distance inside."""
        ws = self.workspace
        loads = (f' load-feasible with {self.payload:g} kg payload (of {self.reachable_volume * 1e3:.1f} L '
                 'reachable)' if self.payload > 0.0 else '')
        return (f'{ws.volume * 1e3:.1f} L at this orientation{loads} ({ws.spacing * 1e3:.0f} mm grid); '
                f'ring_b {self.distance(position) * 1e3:.0f} mm inside its boundary')


class WorkspaceView:
    """Reachable workspace at the slave's current orientation, recomputed in the background."""

    def __init__(self, geometry: RobotGeometry, *, resolution: float = 0.02,
                 angle_step: float = 0.03):
        if not (resolution > 0.0 and angle_step > 0.0):
            raise ValueError('resolution and angle_step must be > 0')
        self.geometry = geometry
        self.resolution = resolution
        self.angle_step = angle_step
        self._lock = threading.Lock()
        self._snapshot: WorkspaceSnapshot | None = None
        self._wanted: tuple | None = None
        self._payload = 0.0
        self._plain: tuple[np.ndarray, Workspace] | None = None
        self._busy = False
        self._version = 0

    def request(self, quaternion_xyzw, world_q_a=(0.0, 0.0, 0.0, 1.0)) -> None:
        """Ask for the workspace at this orientation with ring_a turned by ``world_q_a`` in the
        world (no-op while the last one is close enough and the payload is the same)."""
        q, qa = np.asarray(quaternion_xyzw, dtype=float), np.asarray(world_q_a, dtype=float)
        with self._lock:
            current = self._wanted if self._wanted is not None else (None if self._snapshot is None else (
                self._snapshot.quaternion_xyzw, self._snapshot.world_q_a, self._snapshot.payload))
            if (current is not None and rotation_angle_between(current[0], q) < self.angle_step
                    and rotation_angle_between(current[1], qa) < self.angle_step and current[2] == self._payload):
                return
            self._start((q, qa, self._payload))

    def set_payload(self, mass: float) -> None:
        """The payload [kg] on ring_b: the workspace is recomputed under it (ValueError if < 0)."""
        if not mass >= 0.0:
            raise ValueError(f'payload must be >= 0 kg, got {mass!r}')
        with self._lock:
            self._payload = float(mass)
            last = self._wanted or (None if self._snapshot is None else (
                self._snapshot.quaternion_xyzw, self._snapshot.world_q_a))
            if last is not None:
                self._start((last[0], last[1], self._payload))

    def _start(self, wanted: tuple) -> None:
        """With the lock held: compute ``wanted`` next, in the worker (started if idle)."""
        self._wanted = wanted
        if not self._busy:  # else the worker picks the newest request when it is done
            self._busy = True
            threading.Thread(target=self._work, name='viewer-workspace', daemon=True).start()

    def _compute(self, q, qa, mass) -> WorkspaceSnapshot:
        t0 = time.monotonic()
        if self._plain is None or rotation_angle_between(self._plain[0], q) > 0.0:
            self._plain = (q, reachable_workspace(self.geometry, q, resolution=self.resolution))
        plain = self._plain[1]
        ws = load_workspace(self.geometry, plain=plain, world_q_support=qa,
                            payload=Payload(ring='ring_b', mass=mass) if mass > 0.0 else None)
        boundary, singular = boundary_points(ws)
        return WorkspaceSnapshot(q, ws, boundary, singular, time.monotonic() - t0, 0, qa, mass, plain.volume)

    def _work(self) -> None:
        while True:
            with self._lock:
                wanted, self._wanted = self._wanted, None
                if wanted is None:
                    self._busy = False
                    return
            try:
                snapshot = self._compute(*wanted)
            except BaseException:
                with self._lock:
                    self._busy = False
                raise
            with self._lock:
                self._version += 1
                self._snapshot = dataclasses.replace(snapshot, version=self._version)

    def latest(self) -> WorkspaceSnapshot | None:
        with self._lock:
            return self._snapshot
