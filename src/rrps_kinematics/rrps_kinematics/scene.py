"""Pure scene logic of the viewer: where the rings and legs are in the world and how to colour them.

No rclpy, no viser; the gripping ring is fixed in ``world`` and places a_T_b (docs/robot-model.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_kinematics.limits import Margins, PoseMargins, pose_margins

__all__ = [
    'RobotFigure',
    'robot_figure',
    'FigureCache',
    'world_ring_poses',
    'leg_margin_fractions',
    'margin_colours',
    'torus_mesh',
    'Trail',
    'WARN_FRACTION',
]

#: A leg whose smallest normalised margin is below this is drawn amber, below 0 red.
WARN_FRACTION = 0.25

_GREEN = np.array([40.0, 170.0, 70.0])
_AMBER = np.array([245.0, 170.0, 0.0])
_RED = np.array([220.0, 40.0, 40.0])
_VIOLATED = np.array([150.0, 0.0, 120.0])


def world_ring_poses(*, a_T_b: Pose, gripping: str, world_T_gripping: Pose) -> tuple[Pose, Pose]:
    """(world_T_a, world_T_b) from the kinematic pose and the pose of the gripping ring.

    ``gripping`` is ``'ring_a'`` or ``'ring_b'``: the ring fixed to the structure.
    """
    if gripping == 'ring_a':
        return world_T_gripping, world_T_gripping.compose(a_T_b)
    if gripping == 'ring_b':
        return world_T_gripping.compose(a_T_b.inverse()), world_T_gripping
    raise ValueError(f"gripping must be 'ring_a' or 'ring_b', got {gripping!r}")


def leg_margin_fractions(geometry: RobotGeometry, m: Margins | PoseMargins,
                         efforts: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per-leg margins over their range (1 far from the limit, 0 at it, < 0 beyond): ``stroke`` (over
    half the stroke), ``joint`` (the smaller cone margin over its max angle), ``force`` (1 - |effort| /
    max_force; 1 when unknown) and ``leg``, the smallest of the three, which colours the leg."""
    g = geometry
    half_stroke = 0.5 * (g.max_length - g.min_length)
    stroke = (np.asarray(m.stroke, dtype=float) / half_stroke if math.isfinite(half_stroke)
              else np.ones(6))
    joint = np.minimum(np.asarray(m.universal) / g.universal_max_angle,
                       np.asarray(m.spherical) / g.spherical_max_angle)
    if efforts is None or not math.isfinite(g.max_force):
        force = np.ones(6)
    else:
        e = np.asarray(efforts, dtype=float)
        if e.shape != (6,):
            raise ValueError(f'efforts must have shape (6,), got {e.shape}')
        force = 1.0 - np.abs(e) / g.max_force
    leg = np.minimum(np.minimum(stroke, joint), force)
    # NaN (a failed solve) counts as a violation, like limits.margins.
    leg = np.where(np.isfinite(leg), leg, -1.0)
    return {'stroke': stroke, 'joint': joint, 'force': force, 'leg': np.minimum(leg, 1.0)}


def margin_colours(fractions: np.ndarray, *, warn: float = WARN_FRACTION) -> np.ndarray:
    """RGB uint8 colours (N, 3) for normalised margins: green above ``warn``, amber towards
    0, red at 0, purple beyond the limit (< 0)."""
    f = np.asarray(fractions, dtype=float).reshape(-1)
    t = np.clip(f / warn, 0.0, 1.0)[:, None]
    colour = np.where(t >= 0.5, _AMBER + (2.0 * t - 1.0) * (_GREEN - _AMBER),
                      _RED + 2.0 * t * (_AMBER - _RED))
    colour = np.where((f < 0.0)[:, None], _VIOLATED, colour)
    return np.round(colour).astype(np.uint8)


def torus_mesh(*, radius: float, tube: float, segments: int = 48,
               tube_segments: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A torus about the z axis of its own frame (a ring): (vertices (V, 3) float32, faces (F, 3))."""
    if not (radius > 0.0 and tube > 0.0 and segments >= 3 and tube_segments >= 3):
        raise ValueError('torus_mesh needs radius > 0, tube > 0 and at least 3 segments each way')
    u = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    v = np.linspace(0.0, 2.0 * np.pi, tube_segments, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing='ij')
    r = radius + tube * np.cos(vv)
    vertices = np.stack([r * np.cos(uu), r * np.sin(uu), tube * np.sin(vv)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(segments), np.arange(tube_segments), indexing='ij')
    a = i * tube_segments + j
    b = ((i + 1) % segments) * tube_segments + j
    c = ((i + 1) % segments) * tube_segments + (j + 1) % tube_segments
    d = i * tube_segments + (j + 1) % tube_segments
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                            np.stack([a, c, d], -1).reshape(-1, 3)])
    return vertices.astype(np.float32), faces.astype(np.uint32)


@dataclass(frozen=True)
class RobotFigure:
    """Everything the viewer draws of one robot, in the ``world`` frame.

    ``leg_points`` (6, 2, 3): each leg from its universal-joint centre (on ring_a) to its
    spherical-joint centre (on ring_b); ``leg_colours`` (6, 3) uint8 from ``fractions['leg']``.
    """

    world_T_a: Pose
    world_T_b: Pose
    leg_points: np.ndarray
    margins: PoseMargins
    fractions: dict[str, np.ndarray]
    leg_colours: np.ndarray

    @property
    def lengths(self) -> np.ndarray:
        """Leg lengths [m] at the drawn pose."""
        return np.asarray(self.margins.lengths)


def robot_figure(geometry: RobotGeometry, *, a_T_b: Pose, world_T_a: Pose,
                 efforts: np.ndarray | None = None) -> RobotFigure:
    """Rings, legs and margin colours of ``geometry`` at ``a_T_b`` with ring_a at ``world_T_a``."""
    m = pose_margins(geometry, a_T_b.position, a_T_b.quaternion_xyzw)  # compiled: a few us a frame
    fractions = leg_margin_fractions(geometry, m, efforts)
    world_T_b = world_T_a.compose(a_T_b)
    starts = world_T_a.apply(geometry.ring_a_anchors)
    ends = world_T_b.apply(geometry.ring_b_anchors)
    return RobotFigure(world_T_a=world_T_a, world_T_b=world_T_b,
                       leg_points=np.stack([starts, ends], axis=1), margins=m,
                       fractions=fractions, leg_colours=margin_colours(fractions['leg']))


class FigureCache:
    """:func:`robot_figure` per key (slave, master), recomputed only when its inputs changed: a
    still robot costs nothing."""

    def __init__(self):
        self._cached: dict[str, tuple] = {}

    def __call__(self, key: str, geometry: RobotGeometry, a_T_b: Pose, world_T_a: Pose,
                 efforts: np.ndarray | None = None) -> RobotFigure:
        inputs = (a_T_b.position.tobytes(), a_T_b.quaternion_xyzw.tobytes(),
                  world_T_a.position.tobytes(), world_T_a.quaternion_xyzw.tobytes(),
                  None if efforts is None else np.asarray(efforts).tobytes())
        cached = self._cached.get(key)
        if cached is None or cached[0] != inputs:
            cached = (inputs, robot_figure(geometry, a_T_b=a_T_b, world_T_a=world_T_a, efforts=efforts))
            self._cached[key] = cached
        return cached[1]


class Trail:
    """The world path of a ring (its odometry): a point is kept when it moved ``min_step`` [m]."""

    def __init__(self, *, min_step: float = 0.005, max_points: int = 2000):
        if not (min_step > 0.0 and max_points >= 2):
            raise ValueError('Trail needs min_step > 0 and max_points >= 2')
        self._min_step = min_step
        self._max_points = max_points
        self._points: list[np.ndarray] = []
        self._array: np.ndarray | None = None  # the points as one array, built when asked

    def add(self, position: np.ndarray) -> bool:
        """Append a world position if it moved far enough; return whether it was kept."""
        p = np.asarray(position, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f'trail point must be 3 finite numbers, got {position!r}')
        if self._points and np.linalg.norm(p - self._points[-1]) < self._min_step:
            return False
        self._points.append(p)
        if len(self._points) > self._max_points:
            del self._points[0]
        self._array = None
        return True

    @property
    def points(self) -> np.ndarray:
        """(N, 3) world positions, oldest first (read-only; rebuilt only after a point was kept)."""
        if self._array is None:
            self._array = np.array(self._points).reshape(-1, 3)
            self._array.setflags(write=False)
        return self._array
