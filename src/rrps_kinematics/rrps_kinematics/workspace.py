"""Reachable workspace of an RRPS robot: the ring_b positions within every limit (§3.1).

On a grid of ring_b positions (a_T_b's translation, ring_a's frame): at one orientation, reachable is
``limits.margins(...).ok``; over several (:func:`orientation_range`), reachable at every one (the
total-orientation workspace). Near-singular points, ``excluded_by`` and the grid are defined in
docs/usage.md, 'Command-line tools'. One kernel (:mod:`.compiled_workspace`); no ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy import ndimage

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_multiply_xyzw, quat_xyzw_to_matrix, rotation_vector_to_quat_xyzw
from rrps_kinematics.backend import PARALLEL_BATCH, interpreted, run_parallel, use_numba
from rrps_kinematics.limits import LIMIT_KINDS, limit_arrays

__all__ = [
    'LIMIT_KINDS',
    'SINGULAR_THRESHOLD',
    'UNREACHABLE',
    'REACHABLE',
    'NEAR_SINGULAR',
    'MAX_GRID_POINTS',
    'MAX_ORIENTATIONS',
    'Workspace',
    'orientation_range',
    'automatic_bounds',
    'reachable_workspace',
    'distance_to_boundary',
]

#: The limits in the order in which they exclude a point (the kinds of ``Margins.minimum``).
#: Default near-singular threshold on the inverse condition number: the teleop guard's
#: ``TeleopConfig.singularity_slowdown``, below which motion towards a singularity slows down.
SINGULAR_THRESHOLD = 0.08
#: Values of ``Workspace.labels``: outside a limit; within every limit; within every limit but
#: with an inverse condition number below the near-singular threshold.
UNREACHABLE, REACHABLE, NEAR_SINGULAR = 0, 1, 2
#: Largest grid accepted (about 10 bytes of working memory per point).
MAX_GRID_POINTS = 20_000_000
#: Largest number of orientations of a range.
MAX_ORIENTATIONS = 10_000
_WITHIN_LIMITS = len(LIMIT_KINDS)  # status of a point within every limit, as in compiled_workspace


@dataclass(frozen=True, eq=False)
class Workspace:
    """A reachable workspace on a grid (definitions: docs/usage.md, 'Command-line tools').

    ``labels[i, j, k]`` (int8) classifies the point ``origin + spacing * (i, j, k)`` [m, ring_a]
    as UNREACHABLE, REACHABLE or NEAR_SINGULAR; ``orientations`` (K, 4) are the unit quaternions
    (x, y, z, w) of ring_b in ring_a at which every reachable point is within the limits.
    """

    robot: str
    orientations: np.ndarray
    origin: np.ndarray
    spacing: float
    labels: np.ndarray = field(repr=False)
    excluded_by: dict
    singular_threshold: float

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.labels.shape

    @property
    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The grid's x, y and z coordinates [m]."""
        return _axes(self.origin, self.spacing, self.shape)

    @property
    def bounds(self) -> np.ndarray:
        """[xmin, xmax, ymin, ymax, zmin, zmax] of the grid points [m]."""
        return np.array([v for axis in self.axes for v in (axis[0], axis[-1])])

    @property
    def cell_volume(self) -> float:
        return self.spacing ** 3

    def _points(self, mask: np.ndarray) -> np.ndarray:
        return self.origin + self.spacing * np.argwhere(mask)

    @property
    def reachable(self) -> np.ndarray:
        """(N, 3) positions within every limit [m], the near-singular ones included."""
        return self._points(self.labels != UNREACHABLE)

    @property
    def near_singular(self) -> np.ndarray:
        """(M, 3) reachable positions whose inverse condition number is below the threshold [m]."""
        return self._points(self.labels == NEAR_SINGULAR)

    @cached_property
    def counts(self) -> dict[str, int]:
        """Grid points: ``total``, ``reachable`` (near-singular included), ``near_singular``,
        ``unreachable``."""
        n = np.bincount(self.labels.ravel(), minlength=3)
        return {'total': int(self.labels.size), 'reachable': int(n[REACHABLE] + n[NEAR_SINGULAR]),
                'near_singular': int(n[NEAR_SINGULAR]), 'unreachable': int(n[UNREACHABLE])}

    @property
    def volume(self) -> float:
        """Reachable volume [m^3]: reachable points times the cell volume."""
        return self.counts['reachable'] * self.cell_volume

    @property
    def near_singular_volume(self) -> float:
        """Near-singular volume [m^3] (part of ``volume``)."""
        return self.counts['near_singular'] * self.cell_volume

    @cached_property
    def signed_distance(self) -> np.ndarray:
        """Signed distance [m] of each point of the grid, padded by one unreachable layer, to the
        boundary of the reachable set (positive inside), placed half-way between the cells."""
        inside = np.pad(self.labels != UNREACHABLE, 1)
        if not inside.any():
            return np.full(inside.shape, -math.inf)
        h = self.spacing
        return np.where(inside, ndimage.distance_transform_edt(inside) * h - 0.5 * h,
                        0.5 * h - ndimage.distance_transform_edt(~inside) * h)


def _axes(origin: np.ndarray, spacing: float, shape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coordinates origin[d] + spacing * k of the grid's axes, as ``Workspace._points`` computes them."""
    return tuple(origin[d] + spacing * np.arange(n) for d, n in enumerate(shape))


def _unit_quaternions(quaternion_xyzw, what: str) -> np.ndarray:
    q = np.asarray(quaternion_xyzw, dtype=float)
    if q.ndim not in (1, 2) or q.shape[-1] != 4 or q.size == 0:
        raise ValueError(f'{what} must have shape (4,) or (K, 4), got {q.shape}')
    if not np.all(np.isfinite(q)):
        raise ValueError(f'{what} contains NaN or infinite values')
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError(f'{what}: quaternion has zero norm')
    return (q / norm).reshape(-1, 4)


def orientation_range(quaternion_xyzw, *, roll=(0.0, 0.0), pitch=(0.0, 0.0), yaw=(0.0, 0.0),
                      step: float = 0.05) -> np.ndarray:
    """Sampled orientations of ring_b in ring_a: (K, 4) unit quaternions (x, y, z, w),
    R = Rz(yaw) Ry(pitch) Rx(roll) R0 (R0 = ``quaternion_xyzw``; ring_a's fixed axes, [rad]). Each
    interval is sampled at both ends and at most ``step`` apart; every combination, roll fastest."""
    q0 = _unit_quaternions(quaternion_xyzw, 'quaternion_xyzw')
    if q0.shape[0] != 1:
        raise ValueError('orientation_range takes one orientation')
    if not (math.isfinite(step) and step > 0.0):
        raise ValueError(f'angle step must be finite and > 0, got {step!r}')
    samples = []
    for name, interval in (('roll', roll), ('pitch', pitch), ('yaw', yaw)):
        lo, hi = (float(v) for v in interval)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(f'{name} range must be finite with min <= max, got {tuple(interval)!r}')
        samples.append(np.linspace(lo, hi, int(math.ceil((hi - lo) / step - 1e-9)) + 1))
    count = math.prod(len(s) for s in samples)
    if count > MAX_ORIENTATIONS:
        raise ValueError(f'{count} orientations > {MAX_ORIENTATIONS}: use a larger angle step')
    yaw_, pitch_, roll_ = (a.ravel() for a in np.meshgrid(samples[2], samples[1], samples[0],
                                                          indexing='ij'))
    zeros = np.zeros_like(roll_)
    qx = rotation_vector_to_quat_xyzw(np.stack([roll_, zeros, zeros], axis=-1))
    qy = rotation_vector_to_quat_xyzw(np.stack([zeros, pitch_, zeros], axis=-1))
    qz = rotation_vector_to_quat_xyzw(np.stack([zeros, zeros, yaw_], axis=-1))
    return quat_multiply_xyzw(qz, quat_multiply_xyzw(qy, quat_multiply_xyzw(qx, q0)))


def automatic_bounds(geometry: RobotGeometry, orientations) -> np.ndarray:
    """[xmin, xmax, ymin, ymax, zmin, zmax] [m] holding every ring_b position at which, for one of
    the ``orientations`` (4,) or (K, 4), each leg is within the stroke and inside its universal
    joint's cone (leg i's spherical joint centre then lies in a spherical sector around the
    U-joint's neutral axis, whose bounding box is exact). ValueError for an unbounded stroke,
    or when no position qualifies."""
    g = geometry
    if not math.isfinite(g.max_length):
        raise ValueError(f'{g.name}: the stroke is unbounded (max_length = inf): give the bounds')
    Q = _unit_quaternions(orientations, 'orientations')
    axes = np.asarray(g.ring_a_joint_axes)                                # (6, 3) unit
    angle = np.arccos(np.clip(np.stack([axes, -axes]), -1.0, 1.0))      # (2, 6, 3): to +e_d, -e_d
    # Largest e . u over the cone's unit vectors u, then over lengths in [min, max]: the sector's
    # reach along +e_d and -e_d from the U-joint centre.
    best = np.cos(np.maximum(angle - g.universal_max_angle, 0.0))
    reach = np.where(best > 0.0, g.max_length * best, g.min_length * best)
    b_in_a = np.einsum('kij,nj->kni', quat_xyzw_to_matrix(Q), g.ring_b_anchors)   # (K, 6, 3)
    centres = g.ring_a_anchors - b_in_a                                # p = S-joint - R s'_i
    hi = np.min(centres + reach[0], axis=1)
    lo = np.max(centres - reach[1], axis=1)
    nonempty = np.all(lo <= hi, axis=1)
    if not nonempty.any():
        raise ValueError(f'{g.name}: no position has every leg within the stroke and its universal '
                         'joint cone at these orientations (the workspace is empty)')
    lo, hi = lo[nonempty].min(axis=0), hi[nonempty].max(axis=0)
    return np.column_stack([lo, hi]).ravel()


def _grid(bounds, resolution: float, automatic: bool) -> tuple[np.ndarray, tuple[int, int, int]]:
    """Origin [m] and shape of the grid over ``bounds``: explicit bounds are sampled from their
    minima; automatic ones at multiples of the spacing, one cell beyond them."""
    lo, hi = np.asarray(bounds[0::2]), np.asarray(bounds[1::2])
    if automatic:
        first, last = np.floor(lo / resolution) - 1, np.ceil(hi / resolution) + 1
        return resolution * first, tuple(int(n) for n in last - first + 1)
    return lo.copy(), tuple(int(n) for n in np.floor((hi - lo) / resolution + 1e-9) + 1)


def _check_bounds(bounds) -> np.ndarray:
    b = np.asarray(bounds, dtype=float)
    if b.shape != (6,) or not np.all(np.isfinite(b)):
        raise ValueError(f'bounds must be 6 finite numbers xmin,xmax,ymin,ymax,zmin,zmax, got {bounds!r}')
    for name, lo, hi in zip('xyz', b[0::2], b[1::2]):
        if lo > hi:
            raise ValueError(f'bounds: {name}min {lo:g} > {name}max {hi:g}')
    return b


def _classify(geometry: RobotGeometry, axes, Q: np.ndarray, numba: bool) -> tuple[np.ndarray, np.ndarray]:
    """Status (first limit broken, or _WITHIN_LIMITS) and smallest 1/cond of every grid point:
    the kernel of :mod:`.compiled_workspace`, compiled (on every thread when large enough) or
    interpreted on lists."""
    from rrps_kinematics import compiled_workspace as kernels
    shape = tuple(len(a) for a in axes)
    if not numba:
        status = [[[0] * shape[2] for _ in range(shape[1])] for _ in range(shape[0])]
        inv_cond = [[[0.0] * shape[2] for _ in range(shape[1])] for _ in range(shape[0])]
        interpreted(kernels.classify_grid)(limit_arrays(geometry, lists=True), *(a.tolist() for a in axes),
                                           Q.tolist(), status, inv_cond)
        return np.array(status, dtype=np.int8).reshape(shape), np.array(inv_cond, dtype=float).reshape(shape)
    status = np.empty(shape, dtype=np.int8)
    inv_cond = np.empty(shape)
    args = (limit_arrays(geometry), *(np.ascontiguousarray(a) for a in axes), np.ascontiguousarray(Q),
            status, inv_cond)
    if not (status.size * len(Q) >= PARALLEL_BATCH and run_parallel(kernels.classify_grid_parallel, *args)):
        kernels.classify_grid(*args)
    return status, inv_cond


def reachable_workspace(geometry: RobotGeometry, orientations=None, *, resolution: float,
                        bounds=None, singular_threshold: float = SINGULAR_THRESHOLD,
                        backend: str = 'auto') -> Workspace:
    """The reachable ring_b positions of a_T_b on a grid (§3.1): ``orientations`` one quaternion
    (default home) or (K, 4) from :func:`orientation_range`, ``resolution`` [m], ``bounds`` [m] in
    ring_a (default :func:`automatic_bounds`). ValueError for bad arguments or a grid of more than
    ``MAX_GRID_POINTS``."""
    Q = _unit_quaternions(geometry.home_quaternion_xyzw if orientations is None else orientations,
                          'orientations')
    if len(Q) > MAX_ORIENTATIONS:
        raise ValueError(f'{len(Q)} orientations > {MAX_ORIENTATIONS}')
    resolution = float(resolution)
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise ValueError(f'resolution must be finite and > 0, got {resolution!r}')
    threshold = float(singular_threshold)
    if not (0.0 <= threshold <= 1.0):
        raise ValueError(f'singular_threshold must be in [0, 1], got {singular_threshold!r}')
    automatic = bounds is None
    box = automatic_bounds(geometry, Q) if automatic else _check_bounds(bounds)
    origin, shape = _grid(box, resolution, automatic)
    total = math.prod(shape)
    if total > MAX_GRID_POINTS:
        raise ValueError(f'the grid would have {total:,} points > {MAX_GRID_POINTS:,}: '
                         'use a coarser resolution or smaller bounds')
    status, inv_cond = _classify(geometry, _axes(origin, resolution, shape), Q, use_numba(backend))
    within = status == _WITHIN_LIMITS
    labels = np.where(within, np.where(inv_cond < threshold, NEAR_SINGULAR, REACHABLE),
                      UNREACHABLE).astype(np.int8)
    counts = np.bincount(status.ravel(), minlength=len(LIMIT_KINDS) + 1)
    return Workspace(robot=geometry.name, orientations=Q, origin=origin, spacing=resolution, labels=labels,
                     excluded_by={k: int(counts[i]) for i, k in enumerate(LIMIT_KINDS)},
                     singular_threshold=threshold)


def distance_to_boundary(workspace: Workspace, position) -> float | np.ndarray:
    """Signed distance [m] from ring_b's position(s) (3,) or (N, 3) [m, ring_a] to the reachable set's
    boundary: positive inside, -inf when nothing is reachable. The grid's Euclidean distance transform
    interpolated trilinearly (about a cell accurate); beyond the grid, the nearest point's value minus
    the distance to it."""
    p = np.asarray(position, dtype=float)
    if p.shape[-1:] != (3,) or p.ndim > 2:
        raise ValueError(f'position must have shape (3,) or (N, 3), got {p.shape}')
    if not np.all(np.isfinite(p)):
        raise ValueError('position contains NaN or infinite values')
    if not np.any(workspace.labels != UNREACHABLE):
        value = np.full(p.size // 3, -math.inf)
    else:
        h = workspace.spacing
        index = (p.reshape(-1, 3) - (workspace.origin - h)) / h          # the padded grid's indices
        clamped = np.clip(index, 0.0, np.array(workspace.signed_distance.shape) - 1.0)
        value = ndimage.map_coordinates(workspace.signed_distance, clamped.T, order=1, mode='nearest')
        value = value - h * np.linalg.norm(index - clamped, axis=-1)
    return float(value[0]) if p.ndim == 1 else value
