"""The slave's reachable workspace for the viewer, kept up to date off the drawing thread.

The operator sees where ring_b can go at its current orientation (paper section 3.1: the
master robot lets the operator cope with "the reachable spaces inside the universe of work of
the robot") before moving there. :class:`WorkspaceView` recomputes
:func:`rrps_kinematics.workspace.reachable_workspace` in a worker thread whenever the orientation
changed by more than ``angle_step`` (at most one computation at a time, the newest orientation
wins) and keeps the boundary of the reachable set, which is what is drawn (light and readable,
the robot stays visible inside it). No rclpy, no viser.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import rotation_angle_between
from rrps_kinematics.workspace import (
    NEAR_SINGULAR,
    UNREACHABLE,
    Workspace,
    distance_to_boundary,
    reachable_workspace,
)

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
    """One computed workspace: at orientation ``quaternion_xyzw``, its boundary and near-singular
    points (ring_a frame) and how long it took [s]."""

    quaternion_xyzw: np.ndarray
    workspace: Workspace
    boundary: np.ndarray
    near_singular: np.ndarray
    seconds: float
    version: int

    def distance(self, position) -> float:
        """Distance [m] from ring_b's position to the boundary (positive inside)."""
        return float(distance_to_boundary(self.workspace, position))


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
        self._wanted: np.ndarray | None = None
        self._busy = False
        self._version = 0

    def request(self, quaternion_xyzw) -> None:
        """Ask for the workspace at this orientation (no-op while the last one is close enough)."""
        q = np.asarray(quaternion_xyzw, dtype=float)
        with self._lock:
            current = self._wanted if self._wanted is not None else (
                None if self._snapshot is None else self._snapshot.quaternion_xyzw)
            if current is not None and rotation_angle_between(current, q) < self.angle_step:
                return
            self._wanted = q
            if self._busy:
                return  # the worker picks the newest orientation when it is done
            self._busy = True
        threading.Thread(target=self._work, name='viewer-workspace', daemon=True).start()

    def _work(self) -> None:
        while True:
            with self._lock:
                q, self._wanted = self._wanted, None
                if q is None:
                    self._busy = False
                    return
            t0 = time.monotonic()
            try:
                ws = reachable_workspace(self.geometry, q, resolution=self.resolution)
                boundary, singular = boundary_points(ws)
            except BaseException:
                with self._lock:
                    self._busy = False
                raise
            with self._lock:
                self._version += 1
                self._snapshot = WorkspaceSnapshot(q, ws, boundary, singular,
                                                   time.monotonic() - t0, self._version)

    def latest(self) -> WorkspaceSnapshot | None:
        with self._lock:
            return self._snapshot
