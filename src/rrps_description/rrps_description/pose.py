"""One pose type and one validation policy for every boundary (Python API, nodes, mapping, CLI).

:class:`Pose` is ``parent_T_child`` (position [m], quaternion (x, y, z, w); viser's order is
:attr:`Pose.wxyz`); :func:`validate_pose` is the policy. Pure NumPy, no ROS import."""

from __future__ import annotations

import math

import numpy as np

from rrps_description.rotations import matrix_to_quat_xyzw, quat_xyzw_to_matrix, rotation_angle_between

__all__ = [
    'QUATERNION_TOLERANCE',
    'InvalidPose',
    'Pose',
    'validate_pose',
    'pose_error',
]

#: Largest accepted | |q| - 1 | of a quaternion received at a boundary.
QUATERNION_TOLERANCE = 1e-3


class InvalidPose(ValueError):
    """A pose that must not be used: malformed, not finite, or a non-unit quaternion."""


def validate_pose(position, quaternion_xyzw, *, tolerance: float | None = QUATERNION_TOLERANCE,
                  what: str = 'pose') -> tuple[np.ndarray, np.ndarray]:
    """(position (3,), unit quaternion (4,) in canonical sign: w > 0, for a half turn the first non-zero
    of x, y, z positive) or :class:`InvalidPose`: a wrong shape, NaN/inf, or | |q| - 1 | over ``tolerance``
    (a sender's bug; ``None`` accepts any non-zero norm). ``what`` names the pose in messages.
    """
    try:
        p = np.array(position, dtype=float)
        q = np.array(quaternion_xyzw, dtype=float)
    except (TypeError, ValueError):
        raise InvalidPose(f'{what}: position and quaternion must be numbers, got '
                          f'{position!r}, {quaternion_xyzw!r}') from None
    if p.shape != (3,) or q.shape != (4,):
        raise InvalidPose(f'{what}: position must have shape (3,) and quaternion (4,), got '
                          f'{p.shape} and {q.shape}')
    x, y, z, w = (float(v) for v in q)
    if not all(math.isfinite(v) for v in (float(p[0]), float(p[1]), float(p[2]), x, y, z, w)):
        raise InvalidPose(f'{what}: contains NaN or infinite values')
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm < 1e-12:
        raise InvalidPose(f'{what}: quaternion has zero norm (quaternion norm 0 is not 1)')
    if tolerance is not None and abs(norm - 1.0) > tolerance:
        raise InvalidPose(f'{what}: quaternion norm {norm:.6g} is not 1 (x, y, z, w expected; '
                          f'tolerance {tolerance:g})')
    first = w if w != 0.0 else next((v for v in (x, y, z) if v != 0.0), 1.0)
    q *= (1.0 if first > 0.0 else -1.0) / norm
    return p, q


class Pose:
    """A rigid transform ``parent_T_child``: position [m] (3,) and unit quaternion (x, y, z, w).

    Immutable; built through :func:`validate_pose` (InvalidPose for NaN, wrong shapes or a
    quaternion whose norm is not 1 within ``tolerance``; ``tolerance=None`` normalises any
    non-zero quaternion). ``@`` composes: ``world_T_a @ a_T_b == world_T_b``.
    """

    __slots__ = ('position', 'quaternion_xyzw', '_rotation')

    def __init__(self, position=(0.0, 0.0, 0.0), quaternion_xyzw=(0.0, 0.0, 0.0, 1.0), *,
                 tolerance: float | None = None):
        p, q = validate_pose(position, quaternion_xyzw, tolerance=tolerance)
        p.setflags(write=False)
        q.setflags(write=False)
        object.__setattr__(self, 'position', p)
        object.__setattr__(self, 'quaternion_xyzw', q)
        object.__setattr__(self, '_rotation', None)

    def __setattr__(self, name, value):
        raise AttributeError('Pose is immutable')

    def __copy__(self) -> 'Pose':
        return self

    def __deepcopy__(self, memo) -> 'Pose':
        return self

    def __reduce__(self):
        return Pose, (self.position.copy(), self.quaternion_xyzw.copy())

    @classmethod
    def from_matrix(cls, T) -> 'Pose':
        """From a 4x4 homogeneous transform."""
        T = np.asarray(T, dtype=float)
        if T.shape != (4, 4):
            raise InvalidPose(f'a 4x4 transform is expected, got shape {T.shape}')
        return cls(T[:3, 3], matrix_to_quat_xyzw(T[:3, :3]))

    @classmethod
    def from_rotation(cls, position, rotation) -> 'Pose':
        """From a position (3,) and a rotation matrix (3, 3)."""
        return cls(position, matrix_to_quat_xyzw(np.asarray(rotation, dtype=float)))

    @property
    def rotation(self) -> np.ndarray:
        """3x3 rotation matrix parent_R_child."""
        if self._rotation is None:
            R = quat_xyzw_to_matrix(self.quaternion_xyzw)
            R.setflags(write=False)
            object.__setattr__(self, '_rotation', R)
        return self._rotation

    @property
    def matrix(self) -> np.ndarray:
        """4x4 homogeneous transform parent_T_child (a new array)."""
        T = np.eye(4)
        T[:3, :3] = self.rotation
        T[:3, 3] = self.position
        return T

    @property
    def wxyz(self) -> np.ndarray:
        """The quaternion in (w, x, y, z) order (viser's; the paper's Euler parameters)."""
        x, y, z, w = self.quaternion_xyzw
        return np.array([w, x, y, z])

    def compose(self, other: 'Pose') -> 'Pose':
        """``self @ other``: parent_T_child @ child_T_grandchild = parent_T_grandchild."""
        x1, y1, z1, w1 = self.quaternion_xyzw
        x2, y2, z2, w2 = other.quaternion_xyzw
        q = (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
             w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
             w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
             w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)
        return Pose(self.position + self.rotation @ other.position, q)

    __matmul__ = compose

    def inverse(self) -> 'Pose':
        """child_T_parent."""
        x, y, z, w = self.quaternion_xyzw
        return Pose(-(self.rotation.T @ self.position), (-x, -y, -z, w))

    def apply(self, points) -> np.ndarray:
        """Map points (..., 3) from the child frame to the parent frame."""
        return np.asarray(points, dtype=float) @ self.rotation.T + self.position

    def __eq__(self, other) -> bool:
        return (isinstance(other, Pose) and np.array_equal(self.position, other.position)
                and np.array_equal(self.quaternion_xyzw, other.quaternion_xyzw))

    def __hash__(self) -> int:
        return hash((self.position.tobytes(), self.quaternion_xyzw.tobytes()))

    def __repr__(self) -> str:
        p = ', '.join(f'{v:.6g}' for v in self.position)
        q = ', '.join(f'{v:.6g}' for v in self.quaternion_xyzw)
        return f'Pose(position=[{p}], quaternion_xyzw=[{q}])'


def pose_error(T1: Pose, T2: Pose) -> tuple[float, float]:
    """(distance [m] between the positions, rotation angle [rad] between the orientations)."""
    return (float(np.linalg.norm(T1.position - T2.position)),
            rotation_angle_between(T1.quaternion_xyzw, T2.quaternion_xyzw))
