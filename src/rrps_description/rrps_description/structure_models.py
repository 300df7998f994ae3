"""Structures the robots climb (§3): members with a centreline, beam frames, facades.

A structure is followed along a route of arc length ``s`` [m] and gives ``grip_frame(s)``
(``world_T_grip``: z along a member or out of a surface; x along the route on a surface, along a
fixed section reference on a member), ``swing(s0, s1, spacing)`` (an open gripper's path, ends
included, points at most ``spacing`` apart), ``kind`` ('member' or 'surface'), ``grip_allowed(s)``
and ``forbidden`` (no grip there), ``mesh()`` (vertices, faces) and ``clearance_points(s0, s1)``
(spheres, or None). The shipped ones: :mod:`rrps_description.structures`. No ROS import.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from rrps_description.rotations import (
    matrix_to_quat_xyzw,
    quat_xyzw_to_matrix,
    quat_xyzw_to_rotation_vector,
    rotation_angle_between,
    rotation_vector_to_quat_xyzw,
)

__all__ = ['Structure', 'Tube', 'BeamFrame', 'Facade', 'interpolate_frames']

_DS = 0.002  # resampling step of a spline centreline [m]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _frame_from(z: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """Rotation with columns (x, y, z): z given, x = x_hint made normal to z."""
    z = _unit(np.asarray(z, dtype=float))
    x = x_hint - np.dot(x_hint, z) * z
    if np.linalg.norm(x) < 1e-9:
        raise ValueError('the reference direction is parallel to the member')
    x = _unit(x)
    return np.column_stack([x, np.cross(z, x), z])


def interpolate_frames(p0, R0, p1, R1, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n frames from (p0, R0) to (p1, R1), ends included: straight line and slerp (screw-free)."""
    t = np.linspace(0.0, 1.0, n)
    v = quat_xyzw_to_rotation_vector(matrix_to_quat_xyzw(R0.T @ R1))
    R = R0 @ quat_xyzw_to_matrix(rotation_vector_to_quat_xyzw(t[:, None] * v))
    p = (1.0 - t)[:, None] * np.asarray(p0) + t[:, None] * np.asarray(p1)
    return p, R


def _box_mesh(p0: np.ndarray, p1: np.ndarray, x: np.ndarray, half_width: float):
    """A square-section box from p0 to p1, one side normal to x."""
    z = _unit(p1 - p0)
    x = _unit(x - np.dot(x, z) * z)
    y = np.cross(z, x)
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    verts = [p + half_width * (cx * x + cy * y) for p in (p0, p1) for cx, cy in corners]
    faces = []
    for k in range(4):
        a, b = k, (k + 1) % 4
        faces += [(a, b, 4 + b), (a, 4 + b, 4 + a)]
    faces += [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7)]
    return np.array(verts), np.array(faces, dtype=int)


class Structure(ABC):
    """Common interface (see the module docstring)."""

    name = 'structure'
    kind = 'member'
    length = 0.0
    forbidden: tuple[tuple[float, float], ...] = ()

    @abstractmethod
    def grip_frame(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """See the module docstring."""

    @abstractmethod
    def swing(self, s0: float, s1: float, spacing: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
        """See the module docstring."""

    @abstractmethod
    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """See the module docstring."""

    def clearance_points(self, s0: float, s1: float):
        return None

    def check_s(self, s: float) -> float:
        """``s`` as a float if it lies on the route, else ValueError."""
        s = float(s)
        if not (-1e-9 <= s <= self.length + 1e-9):
            raise ValueError(f'route position {s:.4f} m is off the {self.name} '
                             f'(0 .. {self.length:.4f} m)')
        return min(max(s, 0.0), self.length)

    def grip_allowed(self, s: float) -> bool:
        return 0.0 <= s <= self.length and not any(lo < s < hi for lo, hi in self.forbidden)


class Tube(Structure):
    """A pole, pipe or palm trunk: a cubic-spline centreline through ``points`` with a radius
    varying along it (spline through ``radii``). Grip frames follow the centreline with
    rotation-minimising frames (double reflection, Wang et al. 2008), so the rings do not
    twist about a curved member; ``normal`` fixes x at the foot."""

    kind = 'member'

    def __init__(self, points, radii, *, name: str = 'tube', normal=(1.0, 0.0, 0.0)):
        P = np.asarray(points, dtype=float)
        r = np.asarray(radii, dtype=float)
        if P.ndim != 2 or P.shape[1] != 3 or len(P) < 2:
            raise ValueError('points: expected an (n >= 2, 3) array')
        if r.shape != (len(P),) or not np.all(r > 0.0) or not np.all(np.isfinite(P)):
            raise ValueError('radii: expected one positive radius per point, points finite')
        chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
        if np.any(np.diff(chord) <= 0.0):
            raise ValueError('points: consecutive points must differ')
        self.name = name
        spline = CubicSpline(chord, P, bc_type='natural')
        radius = CubicSpline(chord, r, bc_type='natural')
        u = np.linspace(0.0, chord[-1], max(int(math.ceil(chord[-1] / (_DS / 4))), 8) + 1)
        dense = spline(u)
        s_dense = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
        self.length = float(s_dense[-1])
        n = int(math.ceil(self.length / _DS)) + 1
        self._s = np.linspace(0.0, self.length, n)
        u_s = np.interp(self._s, s_dense, u)
        self._p = spline(u_s)
        self._r = radius(u_s)
        t = _unit(spline(u_s, 1))
        self._R = self._rotation_minimising(self._p, t, np.asarray(normal, dtype=float))
        self.control_points = P
        self.control_radii = r

    @staticmethod
    def _rotation_minimising(p: np.ndarray, t: np.ndarray, normal: np.ndarray) -> np.ndarray:
        x = np.empty_like(t)
        x[0] = _frame_from(t[0], normal)[:, 0]
        for i in range(len(p) - 1):
            v1 = p[i + 1] - p[i]
            c1 = v1 @ v1
            xl = x[i] - (2.0 / c1) * (v1 @ x[i]) * v1
            tl = t[i] - (2.0 / c1) * (v1 @ t[i]) * v1
            v2 = t[i + 1] - tl
            c2 = v2 @ v2
            xn = xl - (2.0 / c2) * (v2 @ xl) * v2 if c2 > 1e-18 else xl
            xn = xn - (xn @ t[i + 1]) * t[i + 1]
            x[i + 1] = xn / np.linalg.norm(xn)
        return np.stack([x, np.cross(t, x), t], axis=-1)

    def radius(self, s) -> np.ndarray:
        """Member radius [m] at route position(s) s."""
        return np.interp(s, self._s, self._r)

    def grip_frame(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        s = self.check_s(s)
        p = np.array([np.interp(s, self._s, self._p[:, k]) for k in range(3)])
        i = min(int(s / _DS), len(self._s) - 2)
        w = (s - self._s[i]) / (self._s[i + 1] - self._s[i])
        z = _unit((1.0 - w) * self._R[i, :, 2] + w * self._R[i + 1, :, 2])
        x = (1.0 - w) * self._R[i, :, 0] + w * self._R[i + 1, :, 0]
        return p, _frame_from(z, x)

    def swing(self, s0: float, s1: float, spacing: float = 0.01):
        n = max(int(math.ceil(abs(s1 - s0) / spacing)), 1) + 1
        frames = [self.grip_frame(s) for s in np.linspace(s0, s1, n)]
        return np.array([f[0] for f in frames]), np.array([f[1] for f in frames])

    def clearance_points(self, s0: float, s1: float):
        lo, hi = sorted((self.check_s(s0), self.check_s(s1)))
        mask = (self._s >= lo) & (self._s <= hi)
        step = max(int(round(0.01 / _DS)), 1)
        return self._p[mask][::step], self._r[mask][::step]

    def mesh(self, sides: int = 24, spacing: float = 0.05):
        idx = np.unique(np.r_[np.arange(0, len(self._s), max(int(spacing / _DS), 1)), len(self._s) - 1])
        ang = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
        ring = np.stack([np.cos(ang), np.sin(ang)], axis=-1)  # (sides, 2)
        R, p, r = self._R[idx], self._p[idx], self._r[idx]
        verts = (p[:, None, :] + r[:, None, None] * (ring[None, :, 0, None] * R[:, None, :, 0]
                                                      + ring[None, :, 1, None] * R[:, None, :, 1]))
        verts = verts.reshape(-1, 3)
        faces = []
        for k in range(len(idx) - 1):
            for j in range(sides):
                a, b = k * sides + j, k * sides + (j + 1) % sides
                faces += [(a, b, b + sides), (a, b + sides, a + sides)]
        return verts, np.array(faces, dtype=int)


@dataclass(frozen=True)
class _Leg:
    s0: float
    length: float
    origin: np.ndarray
    R: np.ndarray


class BeamFrame(Structure):
    """A structural frame: beams between named nodes (§3.1, Figs. 8-9), followed along ``route``.

    Grip frames: z along the beam, x on the section's web (the clamp closes on the flanges), carried
    across a junction by the minimal rotation and turned by ``junction_twist_deg`` per interior node;
    no grip within ``node_clearance`` of one (gusset plates)."""

    kind = 'member'

    def __init__(self, nodes: dict, beams, route, *, web=(1.0, 0.0, 0.0), junction_twist_deg=0.0,
                 node_clearance: float = 0.1, half_width: float = 0.06, name: str = 'frame'):
        self.name = name
        self.nodes = {k: np.asarray(v, dtype=float) for k, v in nodes.items()}
        self.beams = [tuple(b) for b in beams]
        for a, b in self.beams:
            if a not in self.nodes or b not in self.nodes:
                raise ValueError(f'beam ({a}, {b}) names an unknown node')
        route = list(route)
        if len(route) < 2:
            raise ValueError('route: needs at least two nodes')
        beam_set = {frozenset(b) for b in self.beams}
        twists = np.broadcast_to(np.radians(np.asarray(junction_twist_deg, dtype=float)), (len(route) - 2,))
        legs, s = [], 0.0
        R_prev = None
        for a, b in zip(route[:-1], route[1:]):
            if frozenset((a, b)) not in beam_set:
                raise ValueError(f'route: no beam between {a} and {b}')
            p0, p1 = self.nodes[a], self.nodes[b]
            z = _unit(p1 - p0)
            if R_prev is None:
                R = _frame_from(z, np.asarray(web, dtype=float))
            else:
                z_prev = R_prev[:, 2]
                axis = np.cross(z_prev, z)
                angle = math.atan2(np.linalg.norm(axis), float(z_prev @ z))
                turn = quat_xyzw_to_matrix(rotation_vector_to_quat_xyzw(
                    _unit(axis) * angle if angle > 1e-12 else np.zeros(3)))
                R = turn @ R_prev @ quat_xyzw_to_matrix(
                    rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, twists[len(legs) - 1]])))
            legs.append(_Leg(s, float(np.linalg.norm(p1 - p0)), p0, R))
            s += legs[-1].length
            R_prev = R
        self._legs = legs
        self.route = route
        self.length = s
        self.half_width = float(half_width)
        self.junctions = tuple(leg.s0 for leg in legs[1:])
        self.forbidden = tuple((j - node_clearance, j + node_clearance) for j in self.junctions)

    def _leg_at(self, s: float) -> _Leg:
        for leg in reversed(self._legs):
            if s >= leg.s0:
                return leg
        return self._legs[0]

    def grip_frame(self, s: float):
        s = self.check_s(s)
        leg = self._leg_at(s)
        return leg.origin + (s - leg.s0) * leg.R[:, 2], leg.R.copy()

    def swing(self, s0: float, s1: float, spacing: float = 0.01):
        """The open gripper flies clear of the junction: straight line and slerp between the
        two grip frames."""
        p0, R0 = self.grip_frame(s0)
        p1, R1 = self.grip_frame(s1)
        n = max(int(math.ceil(np.linalg.norm(p1 - p0) / spacing)),
                int(math.ceil(np.degrees(rotation_angle_between(R0, R1)))), 1) + 1
        return interpolate_frames(p0, R0, p1, R1, n)

    def mesh(self):
        verts, faces = [], []
        for a, b in self.beams:
            p0, p1 = self.nodes[a], self.nodes[b]
            z = _unit(p1 - p0)
            hint = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            v, f = _box_mesh(p0, p1, hint, self.half_width)
            faces.append(f + sum(len(x) for x in verts))
            verts.append(v)
        return np.concatenate(verts), np.concatenate(faces)


class Facade(Structure):
    """A plane (building front, ship hull): the route is a straight traverse from ``origin``
    along ``direction``; grip frames have z = the outward ``normal`` and x = ``direction``.
    An open gripper lifts by ``lift`` along the normal, moves, and sets down."""

    kind = 'surface'

    def __init__(self, origin=(0.0, 0.0, 0.0), normal=(0.0, -1.0, 0.0), direction=(1.0, 0.0, 0.0),
                 length: float = 4.0, height: float = 3.0, lift: float = 0.03, name: str = 'facade'):
        self.name = name
        self.origin = np.asarray(origin, dtype=float)
        n = _unit(np.asarray(normal, dtype=float))
        self.R = _frame_from(n, np.asarray(direction, dtype=float))
        self.length = float(length)
        self.height = float(height)
        self.lift = float(lift)
        if self.length <= 0.0 or self.lift < 0.0:
            raise ValueError('facade: length must be > 0 and lift >= 0')

    def grip_frame(self, s: float):
        s = self.check_s(s)
        return self.origin + s * self.R[:, 0], self.R.copy()

    def swing(self, s0: float, s1: float, spacing: float = 0.01):
        p0, _ = self.grip_frame(s0)
        p1, _ = self.grip_frame(s1)
        up = self.lift * self.R[:, 2]
        corners = [p0, p0 + up, p1 + up, p1]
        pts = [p0]
        for a, b in zip(corners[:-1], corners[1:]):
            n = max(int(math.ceil(np.linalg.norm(b - a) / spacing)), 1)
            pts += [a + (b - a) * k / n for k in range(1, n + 1)]
        pts = np.array(pts)
        return pts, np.broadcast_to(self.R, (len(pts), 3, 3)).copy()

    def mesh(self):
        x, y = self.R[:, 0], self.R[:, 1]
        o = self.origin - 0.5 * x - 0.5 * self.height * y
        verts = np.array([o, o + (self.length + 1.0) * x, o + (self.length + 1.0) * x + self.height * y,
                          o + self.height * y])
        return verts, np.array([[0, 1, 2], [0, 2, 3]], dtype=int)
