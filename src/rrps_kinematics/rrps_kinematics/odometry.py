"""World odometry of both rings across climbing steps (docs/robot-model.md); pure NumPy.

The gripping ring places a_T_b in the world. A gripping ring's *gripper* stays put, the ring is
``world_T_grip · inv(ring_T_grip)`` (identity, the extra DOF's rotation of §3.1, or a facade ring's
stand-off). Transform batches are (n, 4, 4) matrices (:func:`transform`, :func:`invert`, :func:`rot_z`)."""

from __future__ import annotations

import numpy as np

from rrps_description.pose import Pose

__all__ = ['InterlockError', 'transform', 'invert', 'rot_z', 'RingOdometry']


class InterlockError(ValueError):
    """Both grippers open: the robot would fall (never allowed)."""


def transform(position=(0.0, 0.0, 0.0), rotation=None) -> np.ndarray:
    """4x4 homogeneous transform from a position (3,) and a rotation matrix (3, 3)."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    T[:3, 3] = position
    return T


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transform(s) (..., 4, 4)."""
    T = np.asarray(T, dtype=float)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum('...ij,...j->...i', Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def rot_z(angle) -> np.ndarray:
    """4x4 rotation(s) about z by ``angle`` [rad] (scalar or (n,))."""
    a = np.asarray(angle, dtype=float)
    T = np.zeros(a.shape + (4, 4))
    c, s = np.cos(a), np.sin(a)
    T[..., 0, 0], T[..., 0, 1], T[..., 1, 0], T[..., 1, 1] = c, -s, s, c
    T[..., 2, 2] = T[..., 3, 3] = 1.0
    return T


class RingOdometry:
    """World poses of ring_a and ring_b from successive ``a_T_b`` and gripper states.

    ``world_T_a``: the starting pose of ring_a; ``a_T_b``: the starting kinematic pose.
    ``update`` chains one new ``a_T_b`` (measured or planned) with the current grippers.
    """

    def __init__(self, world_T_a: Pose, a_T_b: Pose, *, a_T_grip: Pose | None = None,
                 b_T_grip: Pose | None = None):
        a_T_grip = Pose() if a_T_grip is None else a_T_grip
        b_T_grip = Pose() if b_T_grip is None else b_T_grip
        self.world_T_a = world_T_a
        self.world_T_b = world_T_a @ a_T_b
        self.world_T_grip_a = self.world_T_a @ a_T_grip
        self.world_T_grip_b = self.world_T_b @ b_T_grip

    def update(self, a_T_b: Pose, grip_a: bool, grip_b: bool, *, a_T_grip: Pose | None = None,
               b_T_grip: Pose | None = None) -> None:
        """Chain ``a_T_b``: the gripping ring's gripper stays where it is; with both gripping,
        ring_a is the reference. ``a_T_grip``/``b_T_grip``: the rings' current gripper mounts
        (identity when omitted). Raises InterlockError when both grippers are open."""
        a_T_grip = Pose() if a_T_grip is None else a_T_grip
        b_T_grip = Pose() if b_T_grip is None else b_T_grip
        if grip_a:
            self.world_T_a = self.world_T_grip_a @ a_T_grip.inverse()
            self.world_T_b = self.world_T_a @ a_T_b
            self.world_T_grip_b = self.world_T_b @ b_T_grip
        elif grip_b:
            self.world_T_b = self.world_T_grip_b @ b_T_grip.inverse()
            self.world_T_a = self.world_T_b @ a_T_b.inverse()
            self.world_T_grip_a = self.world_T_a @ a_T_grip
        else:
            raise InterlockError('both grippers are open')
