"""The world a robot climbs in: its gravity, which ring grips the structure, and how that ring is
turned in the world. Gravity is the world's, never a robot's: :data:`STANDARD_GRAVITY` is
(0, 0, -9.81) m/s² in ``world`` (z up); the physics computes in the supporting ring's frame, where it
is ``support_R_world @ gravity`` (:class:`Support`; docs/robot-model.md). Pure NumPy, no ROS import."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rrps_description.names import RINGS
from rrps_description.pose import QUATERNION_TOLERANCE, validate_pose
from rrps_description.rotations import quat_conjugate_xyzw, quat_multiply_xyzw, quat_xyzw_to_matrix

__all__ = ['STANDARD_GRAVITY', 'IDENTITY_QUATERNION', 'Support', 'handed_over']

#: Gravity in the world frame [m/s²].
STANDARD_GRAVITY = (0.0, 0.0, -9.81)
#: The attitude of a ring standing upright in the world (its frame parallel to the world's).
IDENTITY_QUATERNION = (0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Support:
    """The supporting ring (``'ring_a'`` or ``'ring_b'``), its attitude ``world_q_support``
    (unit quaternion x, y, z, w of the ring's frame in the world) and the world's ``gravity``
    (3,) [m/s²]. Build it with :meth:`of`, which validates."""

    ring: str
    world_q_support: np.ndarray
    gravity: np.ndarray

    @classmethod
    def of(cls, ring: str = 'ring_a', world_q_support=None, gravity=None) -> 'Support':
        """A validated support; ``None`` gives the identity attitude and the standard gravity.
        ValueError naming the argument for a ring that is not one of the two, a quaternion that
        is not unit (within the pose tolerance) or a gravity that is not 3 finite numbers."""
        if ring not in RINGS:
            raise ValueError(f"support: must be 'ring_a' or 'ring_b', got {ring!r}")
        q = IDENTITY_QUATERNION if world_q_support is None else world_q_support
        _, q = validate_pose(np.zeros(3), q, tolerance=QUATERNION_TOLERANCE, what='world_q_support')
        try:
            g = np.array(STANDARD_GRAVITY if gravity is None else gravity, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f'gravity: expected 3 numbers [m/s^2], got {gravity!r}') from None
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f'gravity: expected 3 finite numbers [m/s^2], got {gravity!r}')
        q.setflags(write=False)
        g.setflags(write=False)
        return cls(ring, q, g)

    @property
    def index(self) -> int:
        """0 when ring_a grips (the paper's case), 1 when ring_b grips."""
        return RINGS.index(self.ring)

    @cached_property
    def world_R_support(self) -> np.ndarray:
        """Rotation (3, 3) of the supporting ring's frame in the world."""
        return quat_xyzw_to_matrix(self.world_q_support)

    @cached_property
    def gravity_in_support(self) -> np.ndarray:
        """Gravity (3,) [m/s²] in the supporting ring's frame."""
        g = self.world_R_support.T @ self.gravity
        g.setflags(write=False)
        return g


def handed_over(support: Support, a_q_b, ring: str) -> Support:
    """The support once ``ring`` alone grips, the robot at a_T_b's rotation ``a_q_b`` (x, y, z, w):
    ring_b's world attitude is world_q_a a_q_b, ring_a's world_q_b conj(a_q_b); the world's
    gravity stays. The same support when ``ring`` already grips."""
    if ring == support.ring:
        return support
    q_ab = np.asarray(a_q_b, dtype=float)
    turn = q_ab if ring == 'ring_b' else quat_conjugate_xyzw(q_ab)
    return Support.of(ring, quat_multiply_xyzw(support.world_q_support, turn), support.gravity)
