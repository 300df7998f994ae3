"""A facade that turns a corner (§3.2): two vertical walls meeting at a vertical edge, the route
running horizontally along the first wall and on along the second; a ``'surface'``
:class:`~rrps_description.structures.Structure` as :class:`~rrps_description.structures.Facade`."""

from __future__ import annotations

import math

import numpy as np

from rrps_description.structures import Structure, interpolate_frames

__all__ = ['FacadeCorner', 'facade_corner']


def _frame(normal: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Rotation with columns (x = direction, y = normal x direction, z = normal)."""
    return np.column_stack([direction, np.cross(normal, direction), normal])


class FacadeCorner(Structure):
    """Two vertical walls joined at a vertical edge at route position ``edge`` [m]: the first along
    ``direction`` (outward ``normal``), the second turned ``corner_deg`` about the vertical (> 0: outside
    corner). No grip within ``edge_clearance`` of the edge; a swing lifts ``lift`` off both walls."""

    kind = 'surface'

    def __init__(self, origin=(0.0, 0.0, 1.0), normal=(0.0, -1.0, 0.0), direction=(1.0, 0.0, 0.0), *,
                 edge: float = 2.0, corner_deg: float = 20.0, length: float = 4.0, height: float = 3.0,
                 lift: float = 0.03, edge_clearance: float = 0.06, name: str = 'facade_corner'):
        if not (math.isfinite(corner_deg) and abs(corner_deg) <= 90.0):
            raise ValueError(f'corner_deg must be within -90 .. 90 deg, got {corner_deg!r}')
        if not (0.0 < edge < length and lift >= 0.0 and edge_clearance >= 0.0):
            raise ValueError('facade_corner: 0 < edge < length, lift >= 0 and edge_clearance >= 0')
        n0, d0 = np.asarray(normal, dtype=float), np.asarray(direction, dtype=float)
        if abs(n0[2]) > 1e-9 or abs(d0[2]) > 1e-9 or abs(n0 @ d0) > 1e-9:
            raise ValueError('facade_corner: normal and direction must be horizontal and normal to each other')
        n0, d0 = n0 / np.linalg.norm(n0), d0 / np.linalg.norm(d0)
        c = math.radians(corner_deg)
        turn = np.array([[math.cos(c), -math.sin(c), 0.0], [math.sin(c), math.cos(c), 0.0], [0.0, 0.0, 1.0]])
        if np.cross(d0, n0)[2] > 0.0:  # the wall turns away from the robot about the vertical, either hand
            turn = turn.T
        self.name = name
        self.origin = np.asarray(origin, dtype=float)
        self.edge, self.length, self.height = float(edge), float(length), float(height)
        self.corner_deg, self.lift = float(corner_deg), float(lift)
        self.edge_point = self.origin + self.edge * d0
        self.R = (_frame(n0, d0), _frame(turn @ n0, turn @ d0))
        self.forbidden = ((self.edge - edge_clearance, self.edge + edge_clearance),)

    def wall(self, s: float) -> int:
        """0 on the first wall (s up to the edge), 1 on the second."""
        return 0 if s <= self.edge else 1

    def grip_frame(self, s: float):
        s = self.check_s(s)
        k = self.wall(s)
        return self.edge_point + (s - self.edge) * self.R[k][:, 0], self.R[k].copy()

    def swing(self, s0: float, s1: float, spacing: float = 0.01):
        p0, R0 = self.grip_frame(s0)
        p1, R1 = self.grip_frame(s1)
        n0, n1 = R0[:, 2], R1[:, 2]
        corners = [p0, p0 + self.lift * n0]
        if self.wall(s0) != self.wall(s1):  # round the edge at ``lift`` from both walls
            corners.append(self.edge_point + self.lift * (n0 + n1) / (1.0 + n0 @ n1))
        corners += [p1 + self.lift * n1, p1]
        pts = [p0]
        for a, b in zip(corners[:-1], corners[1:]):
            m = max(int(math.ceil(np.linalg.norm(b - a) / spacing)), 1)
            pts.append(a + (b - a) * (np.arange(1, m + 1) / m)[:, None])
        pts = np.vstack(pts)
        return pts, interpolate_frames(p0, R0, p1, R1, len(pts))[1]

    def mesh(self):
        verts, faces = [], []
        up = np.array([0.0, 0.0, 1.0])
        for k, (a, b) in enumerate(((-0.5, self.edge), (self.edge, self.length + 0.5))):
            x = self.R[k][:, 0]
            o = self.edge_point + (a - self.edge) * x - 0.5 * self.height * up
            verts += [o, o + (b - a) * x, o + (b - a) * x + self.height * up, o + self.height * up]
            faces += [[4 * k, 4 * k + 1, 4 * k + 2], [4 * k, 4 * k + 2, 4 * k + 3]]
        return np.array(verts), np.array(faces, dtype=int)


def facade_corner(corner_deg: float = 20.0, length: float = 4.0) -> FacadeCorner:
    """A building front in the world x-z plane (as :func:`~rrps_description.structures.facade`)
    that turns ``corner_deg`` about the vertical halfway along ``length``."""
    return FacadeCorner(origin=(0.0, 0.0, 1.0), normal=(0.0, -1.0, 0.0), direction=(1.0, 0.0, 0.0),
                        edge=0.5 * length, corner_deg=corner_deg, length=length)
