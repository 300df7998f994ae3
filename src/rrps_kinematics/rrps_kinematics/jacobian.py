"""Inverse Jacobian and statics (velocity and force mapping of eq. 1): ring_b's twist (v, omega)
and wrench in ring_a's frame at ring_b's origin; row i of J is [u_i^T, ((A_c s'_i) × u_i)^T], and
actuator forces f (positive: pushing the rings apart) exert the wrench J^T f on ring_b."""

from __future__ import annotations

import numpy as np

from rrps_description.rotations import cross
from rrps_kinematics.inverse import InverseKinematicsResult

__all__ = ['inverse_jacobian', 'leg_rates', 'platform_wrench', 'leg_forces']


def inverse_jacobian(ik: InverseKinematicsResult) -> np.ndarray:
    """J with leg rates = J @ twist; shape (..., 6, 6)."""
    u = ik.unit_vectors
    b_rot = ik.leg_vectors + ik.geometry.ring_a_anchors - ik.position[..., None, :]  # A_c s'_i
    return np.concatenate([u, cross(b_rot, u)], axis=-1)


def leg_rates(ik: InverseKinematicsResult, twist: np.ndarray) -> np.ndarray:
    """Actuator velocities [m/s] for a ring_b twist (v [m/s], omega [rad/s]) in ring_a's frame."""
    return np.einsum('...ij,...j->...i', inverse_jacobian(ik), np.asarray(twist, dtype=float))


def platform_wrench(ik: InverseKinematicsResult, forces: np.ndarray) -> np.ndarray:
    """Wrench (force [N], moment [N m] about ring_b's origin) on ring_b from actuator forces f: J^T f."""
    return np.einsum('...ji,...j->...i', inverse_jacobian(ik), np.asarray(forces, dtype=float))


def leg_forces(ik: InverseKinematicsResult, wrench: np.ndarray) -> np.ndarray:
    """Actuator forces [N] that balance an external wrench applied to ring_b: J^T f = -wrench.

    Raises numpy.linalg.LinAlgError at a singular pose (no finite forces exist).
    """
    J = inverse_jacobian(ik)
    return -np.linalg.solve(np.swapaxes(J, -1, -2), np.asarray(wrench, dtype=float)[..., None])[..., 0]
