"""Inverse kinematics of an RRPS platform (§2.1, eq. 1).

Leg i's vector ``r_ABi = r + A_c s'_i - s0_i`` for a_T_b = (r, A_c), s'_i = ``ring_b_anchors[i]``
(ring_b frame), s0_i = ``ring_a_anchors[i]`` (ring_a frame); its norm is the actuator length."""

from __future__ import annotations

from functools import cached_property

import numpy as np

from rrps_description.geometry import RobotGeometry, per_geometry
from rrps_description.rotations import cross, matrix_to_euler313, matrix_to_euler_parameters, quat_xyzw_to_matrix
from rrps_kinematics.backend import PARALLEL_BATCH, interpreted, run_parallel, use_numba

__all__ = [
    'InverseKinematicsResult',
    'inverse_kinematics',
    'leg_vectors',
    'universal_joint_frames',
    'lower_link_rotations',
    'leg_lengths',
    'pose_arrays',
]


def leg_vectors(geometry: RobotGeometry, position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Eq. 1: r_ABi = r + A_c s'_i - s0_i, in ring_a's frame; (..., 3), (..., 3, 3) -> (..., 6, 3)."""
    b_in_a = np.einsum('...jk,ik->...ij', rotation, geometry.ring_b_anchors)
    return position[..., None, :] + b_in_a - geometry.ring_a_anchors


@per_geometry
def universal_joint_frames(geometry: RobotGeometry) -> np.ndarray:
    """Frame of each universal joint's fixed yoke in ring_a's frame, shape (6, 3, 3), read-only.

    Columns: x = the first revolute axis, fixed in ring_a, normal to the neutral axis and to the
    anchor vector s0_i (the paper's u_z × s0 construction at the neutral pose); z = the joint's
    neutral axis; y = z × x.
    """
    z = np.asarray(geometry.ring_a_joint_axes)
    s0 = np.asarray(geometry.ring_a_anchors)
    x = cross(z, s0)
    fallback = cross(z, np.array([1.0, 0.0, 0.0]))
    fallback2 = cross(z, np.array([0.0, 1.0, 0.0]))
    bad = np.linalg.norm(x, axis=1) < 1e-9
    x[bad] = np.where(np.linalg.norm(fallback[bad], axis=1, keepdims=True) > 1e-6,
                      fallback[bad], fallback2[bad])
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = cross(z, x)
    frames = np.stack([x, y, z], axis=-1)
    frames.setflags(write=False)
    return frames


def lower_link_rotations(geometry: RobotGeometry, universal_angles: np.ndarray) -> np.ndarray:
    """Rotation of each leg's lower link (z along the leg) from its universal-joint angles.

    ``a_R_link = F_i Rx(theta1) Ry(theta2)`` with F_i the yoke frame: theta1 about the axis fixed
    in ring_a, theta2 about the cross's second axis. Shape (..., 6, 2) -> (..., 6, 3, 3). The
    upper link of a prismatic pair has the same rotation (eqs. 6-8 forbid relative rotation).
    """
    t1 = universal_angles[..., 0]
    t2 = universal_angles[..., 1]
    c1, s1, c2, s2 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
    zeros = np.zeros_like(t1)
    local = np.stack([
        np.stack([c2, zeros, s2], axis=-1),
        np.stack([s1 * s2, c1, -s1 * c2], axis=-1),
        np.stack([-c1 * s2, s1, c1 * c2], axis=-1),
    ], axis=-2)
    return universal_joint_frames(geometry) @ local


def _angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle between unit vectors (..., 3), accurate near 0 and pi (atan2 of |u x v| and u . v)."""
    return np.arctan2(np.linalg.norm(cross(u, v), axis=-1), np.einsum('...k,...k->...', u, v))


class InverseKinematicsResult:
    """Everything §2.1 derives from one pose, or a batch (leading N); ring_a's frame, m, rad.

    ``leg_vectors`` r_ABi (eq. 1), ``lengths``, ``unit_vectors`` u_z, ``ring_b_anchors_in_a``; on
    first access ``leg_frames`` A_i = [u_x, u_y, u_z], as ``leg_euler313`` (psi, alpha, phi) and
    ``leg_euler_parameters``, ``universal_angles`` (:func:`lower_link_rotations`), and each leg's
    ``universal_cone_angles`` and ``spherical_cone_angles`` from its joints' neutral axes.
    """

    def __init__(self, geometry: RobotGeometry, position: np.ndarray, rotation: np.ndarray):
        self.geometry = geometry
        self.position = position
        self.rotation = rotation
        self.leg_vectors = leg_vectors(geometry, position, rotation)
        self.lengths = np.sqrt(np.einsum('...ij,...ij->...i', self.leg_vectors, self.leg_vectors))
        with np.errstate(divide='ignore', invalid='ignore'):
            self.unit_vectors = self.leg_vectors / self.lengths[..., None]

    @cached_property
    def ring_b_anchors_in_a(self) -> np.ndarray:
        return self.leg_vectors + self.geometry.ring_a_anchors

    @cached_property
    def leg_frames(self) -> np.ndarray:
        uz = self.unit_vectors
        s0 = np.broadcast_to(self.geometry.ring_a_anchors, uz.shape)
        ux = cross(uz, s0)
        n = np.linalg.norm(ux, axis=-1, keepdims=True)
        # A leg pointing along its own anchor vector (or an anchor at the origin): use ring_a's x.
        alt = cross(uz, np.array([1.0, 0.0, 0.0]))
        alt2 = cross(uz, np.array([0.0, 1.0, 0.0]))
        alt = np.where(np.linalg.norm(alt, axis=-1, keepdims=True) > 1e-6, alt, alt2)
        ux = np.where(n > 1e-9, ux, alt)
        ux = ux / np.linalg.norm(ux, axis=-1, keepdims=True)
        uy = cross(uz, ux)
        return np.stack([ux, uy, uz], axis=-1)

    @cached_property
    def leg_euler313(self) -> np.ndarray:
        return matrix_to_euler313(self.leg_frames)

    @cached_property
    def leg_euler_parameters(self) -> np.ndarray:
        return matrix_to_euler_parameters(self.leg_frames)

    @cached_property
    def universal_angles(self) -> np.ndarray:
        d = np.einsum('ikj,...ik->...ij', universal_joint_frames(self.geometry), self.unit_vectors)
        theta1 = np.arctan2(-d[..., 1], d[..., 2])
        theta2 = np.arcsin(np.clip(d[..., 0], -1.0, 1.0))
        return np.stack([theta1, theta2], axis=-1)

    @cached_property
    def universal_cone_angles(self) -> np.ndarray:
        return _angle_between(self.unit_vectors, self.geometry.ring_a_joint_axes)

    @cached_property
    def spherical_cone_angles(self) -> np.ndarray:
        # Leg direction from the S-joint towards ring_a, expressed in ring_b's frame.
        towards_a_in_b = -np.einsum('...kj,...ik->...ij', self.rotation, self.unit_vectors)
        return _angle_between(towards_a_in_b, self.geometry.ring_b_joint_axes)

    @cached_property
    def lower_link_rotations(self) -> np.ndarray:
        return lower_link_rotations(self.geometry, self.universal_angles)


def pose_arrays(position, quaternion_xyzw) -> tuple[np.ndarray, np.ndarray]:
    """A pose a_T_b (or a batch) as float arrays: position (..., 3) and unit quaternion (..., 4).

    The one validation of pose input (eq. 1's r and A_c): shapes (3,)/(4,) or (N, 3)/(N, 4) with
    equal batch shapes, finite values, a non-zero quaternion (normalised on return). Raises
    ValueError otherwise.
    """
    p = np.asarray(position, dtype=float)
    q = np.asarray(quaternion_xyzw, dtype=float)
    if p.shape[-1:] != (3,):
        raise ValueError(f'position must have shape (3,) or (N, 3), got {p.shape}')
    if q.shape[-1:] != (4,):
        raise ValueError(f'quaternion_xyzw must have shape (4,) or (N, 4), got {q.shape}')
    if p.shape[:-1] != q.shape[:-1]:
        raise ValueError(f'position {p.shape} and quaternion {q.shape} batch shapes differ')
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise ValueError('pose contains NaN or infinite values')
    norm = np.sqrt(np.einsum('...i,...i->...', q, q))[..., None]  # a third of np.linalg.norm's time
    if np.any(norm < 1e-12):
        raise ValueError('quaternion has zero norm')
    return p, q / norm


def inverse_kinematics(geometry: RobotGeometry, position, quaternion_xyzw) -> InverseKinematicsResult:
    """Eq. 1 for a_T_b given as position [m] and unit quaternion (x, y, z, w), single or (N, ...).

    The quaternion is normalised; NaN/inf, zero quaternions and shape mismatches raise ValueError.
    Poses outside the limits are still solved: see :mod:`rrps_kinematics.limits` for margins.
    """
    p, q = pose_arrays(position, quaternion_xyzw)
    return InverseKinematicsResult(geometry, p, quat_xyzw_to_matrix(q))


def leg_lengths(geometry: RobotGeometry, position, quaternion_xyzw, *, backend: str = 'auto') -> np.ndarray:
    """Actuator lengths only (the batch IK fast path): (3,), (4,) -> (6,); (N, 3), (N, 4) -> (N, 6).

    Equal to ``inverse_kinematics(...).lengths``, from a kernel that skips every other quantity
    (:func:`rrps_kinematics.compiled.ik_lengths_batch`; long compiled batches on every thread).
    """
    from rrps_kinematics import compiled
    p, q = pose_arrays(position, quaternion_xyzw)
    P = np.ascontiguousarray(p.reshape(-1, 3))
    Q = np.ascontiguousarray(q.reshape(-1, 4))
    A, B = (np.ascontiguousarray(a, dtype=float) for a in (geometry.ring_a_anchors, geometry.ring_b_anchors))
    if not use_numba(backend):
        out = [[0.0] * 6 for _ in range(len(P))]
        interpreted(compiled.ik_lengths_batch)(A.tolist(), B.tolist(), P.tolist(), Q.tolist(), out)
        return np.array(out, dtype=float).reshape(p.shape[:-1] + (6,))
    out = np.empty((P.shape[0], 6))
    args = (A, B, P, Q, out)
    if not (P.shape[0] >= PARALLEL_BATCH and run_parallel(compiled.ik_lengths_parallel, *args)):
        compiled.ik_lengths_batch(*args)
    return out.reshape(p.shape[:-1] + (6,))
