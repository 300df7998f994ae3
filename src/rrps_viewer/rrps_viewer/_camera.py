"""The viewer's first view: the camera framed on the robot, its structure and the master once odometry placed it.

:func:`framing` (pure) fits the points' bounding sphere in a view :data:`ASPECT` as wide as high or wider;
:class:`FirstView` applies it to viser's initial camera, the open browsers and each browser that connects."""

from __future__ import annotations

import math
import threading
from typing import Callable, Iterable

import numpy as np

__all__ = ['DIRECTION', 'FOV', 'framing', 'scene_points', 'FirstView']

#: The direction the viewer looks in (unit, world): from the front right, a little from above.
DIRECTION = -np.array([0.9, -1.65, 0.8]) / np.linalg.norm([0.9, -1.65, 0.8])
#: viser's vertical field of view [rad] (its cameras' default).
FOV = math.radians(75.0)
#: The narrowest 3-D view framed for, width / height: the control panel is docked at the window's
#: right (320 px wide) and the view is the rest, 0.87 as wide as high in a window of 860 x 600 px.
ASPECT = 0.8


def framing(points: np.ndarray, *, fov: float = FOV, aspect: float = ASPECT, direction=DIRECTION,
            margin: float = 1.15) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, look_at) [m, world] from which every point of ``points`` (N, 3) is in a
    pinhole view of vertical field ``fov`` [rad] and width/height ``aspect``, with ``margin``."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    radius = max(float(np.max(np.linalg.norm(points - centre, axis=1))), 1e-3)
    half = min(fov, 2.0 * math.atan(aspect * math.tan(0.5 * fov))) / 2.0
    distance = margin * radius / math.sin(half)
    return centre - np.asarray(direction, dtype=float) * distance, centre


def scene_points(robot, master, structure_vertices: np.ndarray | None, reach: float) -> np.ndarray:
    """What the first view shows: the robot (a :class:`rrps_kinematics.scene.RobotFigure` in the
    world: its legs and rings), the master's figure (or None), and the structure's vertices
    within ``reach`` [m] of the robot's centre (the member it climbs, not its whole length)."""
    parts = [robot.leg_points.reshape(-1, 3), robot.world_T_a.position[None], robot.world_T_b.position[None]]
    if master is not None:
        parts.append(master.leg_points.reshape(-1, 3))
    if structure_vertices is not None:
        centre = np.mean(parts[0], axis=0)
        vertices = np.asarray(structure_vertices, dtype=float)
        parts.append(vertices[np.linalg.norm(vertices - centre, axis=1) <= reach])
    return np.concatenate(parts)


class FirstView:
    """Frames the view once, on the first frame with the robot placed by odometry (its trails)."""

    def __init__(self, server, structure_vertices: np.ndarray | None, reach: float):
        self.server = server
        self.structure_vertices = structure_vertices
        self.reach = reach
        self.camera: tuple[np.ndarray, np.ndarray] | None = None
        self._lock = threading.Lock()   # the framing against a browser connecting meanwhile

    def update(self, frame, clients: Callable[[], Iterable]) -> None:
        """Frame the view from ``frame`` if not yet done; ``clients()``: the open viser clients,
        asked once the framing is known (a browser that connects later is framed by :meth:`show`)."""
        if self.camera is not None or frame.slave is None or not frame.trails:
            return
        camera = framing(scene_points(frame.slave, frame.master, self.structure_vertices, self.reach))
        with self._lock:
            self.camera = camera
            position, look_at = self._position_look_at()
            self.server.initial_camera.position, self.server.initial_camera.look_at = position, look_at
            for client in clients():
                self._frame(client)

    def show(self, client) -> None:
        """Frame a browser that has just connected, if the view is framed already: viser moves a
        browser to the initial camera only as its session begins, which may have been before the
        framing, and the browser may have been missing from :meth:`update`'s ``clients()``."""
        with self._lock:
            if self.camera is not None:
                self._frame(client)

    def _position_look_at(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return tuple(tuple(float(v) for v in x) for x in self.camera)

    def _frame(self, client) -> None:
        position, look_at = self._position_look_at()
        with client.atomic():
            client.camera.position, client.camera.look_at = position, look_at
