"""Rotations: 3-1-3 Euler angles, Euler parameters and quaternions (§2.1).

Conventions: ``a_R_b`` maps coordinates in b to a; ``quaternion_xyzw`` is ROS's order and
``euler_parameters`` the paper's (e0, e1, e2, e3) = (w, x, y, z), A = (2 e0^2 - 1) I + 2 (e e^T + e0 ẽ);
3-1-3 angles give A_c = Rz(psi) Rx(alpha) Rz(phi) (eq. 1), URDF's roll, pitch, yaw R = Rz(yaw) Ry(pitch)
Rx(roll). Any leading batch shape; returned quaternions have w >= 0 (a half turn: first non-zero of x, y, z > 0).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    'cross',
    'skew',
    'quat_xyzw_to_matrix',
    'matrix_to_quat_xyzw',
    'euler_parameters_to_matrix',
    'matrix_to_euler_parameters',
    'quat_xyzw_to_euler_parameters',
    'euler_parameters_to_quat_xyzw',
    'euler313_to_matrix',
    'matrix_to_euler313',
    'quat_multiply_xyzw',
    'quat_conjugate_xyzw',
    'rotation_vector_to_quat_xyzw',
    'quat_xyzw_to_rotation_vector',
    'rotation_vector_to_matrix',
    'normalize_quat',
    'rotation_angle_between',
    'rpy_to_matrix',
    'matrix_to_rpy',
]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis (size 3) with broadcasting; np.cross without its overhead."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def skew(v: np.ndarray) -> np.ndarray:
    """The cross-product matrix ṽ with ṽ w = v × w; shape (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def _canonical_sign(p: np.ndarray) -> np.ndarray:
    """+1 or -1 per (e0, e1, e2, e3): makes the first non-zero component positive (e0 > 0 first)."""
    nonzero = p != 0.0
    first = np.argmax(nonzero, axis=-1)
    lead = np.take_along_axis(p, first[..., None], axis=-1)
    return np.where(lead < 0.0, -1.0, 1.0)


def normalize_quat(q: np.ndarray) -> np.ndarray:
    """Unit (x, y, z, w) quaternion of the same rotation in canonical sign: w > 0, or for a half
    turn (w = 0) the first non-zero of x, y, z positive, so that q and -q give identical output."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return q * _canonical_sign(np.concatenate([q[..., 3:], q[..., :3]], axis=-1))


def euler_parameters_to_matrix(p: np.ndarray) -> np.ndarray:
    """A(p) = (2 e0^2 - 1) I + 2 (e e^T + e0 ẽ) for p = (e0, e1, e2, e3) (section 2.1)."""
    p = np.asarray(p, dtype=float)
    e0 = p[..., 0]
    e = p[..., 1:]
    A = (2.0 * e0**2 - 1.0)[..., None, None] * np.eye(3)
    A = A + 2.0 * (e[..., :, None] * e[..., None, :] + e0[..., None, None] * skew(e))
    return A


def quat_xyzw_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a ROS-order unit quaternion (x, y, z, w); shape (..., 4) -> (..., 3, 3).

    The same A(p) as :func:`euler_parameters_to_matrix`, written element by element (faster).
    """
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[..., 0, 1] = 2.0 * (x * y - z * w)
    out[..., 0, 2] = 2.0 * (x * z + y * w)
    out[..., 1, 0] = 2.0 * (x * y + z * w)
    out[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[..., 1, 2] = 2.0 * (y * z - x * w)
    out[..., 2, 0] = 2.0 * (x * z - y * w)
    out[..., 2, 1] = 2.0 * (y * z + x * w)
    out[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return out


def quat_xyzw_to_euler_parameters(q: np.ndarray) -> np.ndarray:
    """(x, y, z, w) -> (e0, e1, e2, e3) = (w, x, y, z)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:4], q[..., :3]], axis=-1)


def euler_parameters_to_quat_xyzw(p: np.ndarray) -> np.ndarray:
    """(e0, e1, e2, e3) = (w, x, y, z) -> (x, y, z, w)."""
    p = np.asarray(p, dtype=float)
    return np.concatenate([p[..., 1:], p[..., 0:1]], axis=-1)


def matrix_to_euler_parameters(A: np.ndarray) -> np.ndarray:
    """Euler parameters (canonical sign, e0 >= 0) of a rotation matrix; robust for every angle
    (Shepperd's method: of the four expressions of 4 e e^T's rows, the one with the largest
    diagonal term 4 e_k^2, normalised)."""
    A = np.asarray(A, dtype=float)
    batch = A.shape[:-2]
    A = A.reshape((-1, 3, 3))
    a00, a11, a22 = A[:, 0, 0], A[:, 1, 1], A[:, 2, 2]
    tr = a00 + a11 + a22
    d32 = A[:, 2, 1] - A[:, 1, 2]  # 4 e0 e1
    d13 = A[:, 0, 2] - A[:, 2, 0]  # 4 e0 e2
    d21 = A[:, 1, 0] - A[:, 0, 1]  # 4 e0 e3
    s01 = A[:, 0, 1] + A[:, 1, 0]  # 4 e1 e2
    s02 = A[:, 0, 2] + A[:, 2, 0]  # 4 e1 e3
    s12 = A[:, 1, 2] + A[:, 2, 1]  # 4 e2 e3
    # 4 e e^T, row by row: row k is 4 e_k e, so any row with e_k != 0 is e up to scale.
    rows = np.stack([np.stack([1.0 + tr, d32, d13, d21], axis=1),
                     np.stack([d32, 1.0 + 2 * a00 - tr, s01, s02], axis=1),
                     np.stack([d13, s01, 1.0 + 2 * a11 - tr, s12], axis=1),
                     np.stack([d21, s02, s12, 1.0 + 2 * a22 - tr], axis=1)], axis=1)
    diagonal = rows[:, [0, 1, 2, 3], [0, 1, 2, 3]]
    p = rows[np.arange(A.shape[0]), np.argmax(diagonal, axis=1)]
    p = p / np.linalg.norm(p, axis=1, keepdims=True)
    p = p * _canonical_sign(p)
    return p.reshape(batch + (4,))


def matrix_to_quat_xyzw(A: np.ndarray) -> np.ndarray:
    """ROS-order quaternion (x, y, z, w), w >= 0, of a rotation matrix."""
    return euler_parameters_to_quat_xyzw(matrix_to_euler_parameters(A))


def _rz(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 1, 1] = c
    out[..., 2, 2] = 1.0
    return out


def _rx(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0] = 1.0
    out[..., 1, 1] = c
    out[..., 1, 2] = -s
    out[..., 2, 1] = s
    out[..., 2, 2] = c
    return out


def euler313_to_matrix(angles: np.ndarray) -> np.ndarray:
    """A_c = Rz(psi) Rx(alpha) Rz(phi) for angles (psi, alpha, phi) (eq. 1's 3-1-3 matrix)."""
    angles = np.asarray(angles, dtype=float)
    return _rz(angles[..., 0]) @ _rx(angles[..., 1]) @ _rz(angles[..., 2])


def matrix_to_euler313(A: np.ndarray, *, gimbal_tolerance: float = 1e-9) -> np.ndarray:
    """3-1-3 Euler angles (psi, alpha, phi) with alpha in [0, pi].

    At gimbal lock (alpha = 0 or pi) only psi ± phi is defined: phi is set to 0 and psi carries
    the whole rotation about z, so ``euler313_to_matrix(matrix_to_euler313(A)) == A`` always.
    """
    A = np.asarray(A, dtype=float)
    c_alpha = np.clip(A[..., 2, 2], -1.0, 1.0)
    s_alpha = np.hypot(A[..., 0, 2], A[..., 1, 2])
    alpha = np.arctan2(s_alpha, c_alpha)
    regular = s_alpha > gimbal_tolerance
    psi_reg = np.arctan2(A[..., 0, 2], -A[..., 1, 2])
    phi_reg = np.arctan2(A[..., 2, 0], A[..., 2, 1])
    # Gimbal lock: A = Rz(psi) Rx(0 or pi) Rz(0); A[1,0] = sin psi, A[0,0] = cos psi.
    psi_lock = np.arctan2(A[..., 1, 0], A[..., 0, 0])
    psi = np.where(regular, psi_reg, psi_lock)
    phi = np.where(regular, phi_reg, 0.0)
    alpha = np.where(regular, alpha, np.where(c_alpha > 0, 0.0, np.pi))
    return np.stack([psi, alpha, phi], axis=-1)


def quat_multiply_xyzw(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Hamilton product q1 ⊗ q2 in (x, y, z, w) order: R(q1 ⊗ q2) = R(q1) R(q2)."""
    q1 = np.asarray(q1, dtype=float)
    q2 = np.asarray(q2, dtype=float)
    if q1.shape == (4,) and q2.shape == (4,):  # one pair (the teleop step): plain floats, same sums
        x1, y1, z1, w1 = q1.tolist()
        x2, y2, z2, w2 = q2.tolist()
        return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                         w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                         w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])
    x1, y1, z1, w1 = q1[..., 0], q1[..., 1], q1[..., 2], q1[..., 3]
    x2, y2, z2, w2 = q2[..., 0], q2[..., 1], q2[..., 2], q2[..., 3]
    return np.stack([
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    ], axis=-1)


def quat_conjugate_xyzw(q: np.ndarray) -> np.ndarray:
    """Inverse of a unit quaternion in (x, y, z, w) order."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([-q[..., :3], q[..., 3:]], axis=-1)


def rotation_vector_to_quat_xyzw(v: np.ndarray) -> np.ndarray:
    """Exponential map: rotation vector (axis · angle, rad) -> unit quaternion (x, y, z, w)."""
    v = np.asarray(v, dtype=float)
    angle = np.linalg.norm(v, axis=-1)
    half = 0.5 * angle
    # sin(half)/angle, with its Taylor series near zero.
    small = angle < 1e-6
    safe = np.where(small, 1.0, angle)
    k = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / safe)
    return np.concatenate([v * k[..., None], np.cos(half)[..., None]], axis=-1)


def quat_xyzw_to_rotation_vector(q: np.ndarray) -> np.ndarray:
    """Logarithm map: unit quaternion (x, y, z, w) -> rotation vector with angle in [0, pi]."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., 3:4] < 0.0, -q, q)
    s = np.linalg.norm(q[..., :3], axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 3])
    small = s < 1e-9
    k = np.where(small, 2.0 / np.maximum(q[..., 3], 1e-300), angle / np.where(small, 1.0, s))
    return q[..., :3] * k[..., None]


def rotation_vector_to_matrix(v: np.ndarray) -> np.ndarray:
    """Rodrigues' formula: rotation vector (rad) -> rotation matrix."""
    return quat_xyzw_to_matrix(rotation_vector_to_quat_xyzw(v))


def rotation_angle_between(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Angle [rad] in [0, pi] of the rotation from orientation 1 to 2, the one such function of rrps:
    rotation matrices (..., 3, 3) or unit quaternions (x, y, z, w) (..., 4); 2 atan2(|e|, |e0|) of the
    relative Euler parameters (robust near 0 and pi); a float for one pair."""
    a = np.asarray(R1, dtype=float)
    b = np.asarray(R2, dtype=float)
    if a.shape[-1:] == (4,) and b.shape[-1:] == (4,):
        r = quat_multiply_xyzw(quat_conjugate_xyzw(a), b)
        vec, scalar = r[..., :3], r[..., 3]
    else:
        q = matrix_to_euler_parameters(np.swapaxes(a, -1, -2) @ b)
        vec, scalar = q[..., 1:], q[..., 0]
    angle = 2.0 * np.arctan2(np.linalg.norm(vec, axis=-1), np.abs(scalar))
    return float(angle) if np.ndim(angle) == 0 else angle


def rpy_to_matrix(rpy) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def matrix_to_rpy(R) -> tuple[float, float, float]:
    """Roll, pitch, yaw of a rotation matrix (the inverse of :func:`rpy_to_matrix`), accurate
    near pitch = ±pi/2 too: yaw first, then pitch and roll from Rz(-yaw) R = Ry(pitch) Rx(roll)."""
    R = np.asarray(R, dtype=float)
    yaw = math.atan2(R[1, 0], R[0, 0]) if math.hypot(R[1, 0], R[0, 0]) > 1e-12 else 0.0
    c, s = math.cos(yaw), math.sin(yaw)
    M = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ R
    return math.atan2(-M[1, 2], M[1, 1]), math.atan2(-M[2, 0], M[0, 0]), yaw
