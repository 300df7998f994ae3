"""The constraints of the multibody model (§2.2, eqs. 2-10): body indexing, each leg's rows and their
analytic Jacobian, compiled with numba or interpreted. :mod:`.multibody` solves the model
(docs/robot-model.md, 'The multibody model'); ``rrps_sim.dynamics`` reuses these kernels."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rrps_kinematics.backend import jit

__all__ = [
    'N_BODIES', 'N_COORDINATES', 'N_JOINT_CONSTRAINTS', 'N_DRIVING', 'N_CONSTRAINTS',
    'FLOPS_ROTATION', 'FLOPS_ROTATE', 'FLOPS_DAS_DP', 'FLOPS_LEG_RESIDUAL', 'FLOPS_LEG_JACOBIAN',
    'FLOPS_NORMALISATION', 'lower_link_body', 'upper_link_body', 'body_slice', 'JointGeometry',
    'rotation', 'rotation_into', 'das_dp', 'leg_residual', 'leg_residual_with_rotations',
    'leg_jacobian', 'all_constraints', 'all_jacobian',
]


N_BODIES = 13
N_COORDINATES = 7 * N_BODIES          # 91
N_JOINT_CONSTRAINTS = 72              # Φ^K: spherical, universal, translational
N_DRIVING = 6                         # Φ^D
N_CONSTRAINTS = N_JOINT_CONSTRAINTS + N_DRIVING + N_BODIES   # 91

# Flop model (multiply and add each count one; sqrt/division one): work done per evaluation.
FLOPS_ROTATION = 28                   # A(p) from Euler parameters
FLOPS_ROTATE = 15                     # A s'
FLOPS_DAS_DP = 40                     # ∂(A s')/∂p, 3 x 4
FLOPS_LEG_RESIDUAL = 2 * FLOPS_ROTATION + 4 * FLOPS_ROTATE + 6 * 5 + 20
FLOPS_LEG_JACOBIAN = 10 * FLOPS_DAS_DP + 14 * 7 + 10 * 8
FLOPS_NORMALISATION = 8               # residual and gradient of p^T p - 1


def lower_link_body(k: int) -> int:
    """Body index of leg k's lower link (k = 0..5)."""
    return 1 + 2 * k


def upper_link_body(k: int) -> int:
    """Body index of leg k's upper link (k = 0..5)."""
    return 2 + 2 * k


def body_slice(b: int) -> slice:
    """Slice of body b's 7 coordinates [r, p] in q."""
    return slice(7 * b, 7 * b + 7)


class JointGeometry(NamedTuple):
    """The joint data of eqs. 3-10 for the compiled kernels: ``a``, ``ha`` (6, 3) the universal joints'
    centres and axes in ring_a, ``sb`` (6, 3) the spherical-joint centres in ring_b's com frame, ``cl``,
    ``cu`` [m] the links' com offsets from their joints (s'_l = (0, 0, -c_l), s'_u = (0, 0, c_u))."""

    a: np.ndarray
    ha: np.ndarray
    sb: np.ndarray
    cl: float
    cu: float


# --- compiled kernels (shared with rrps_sim.dynamics) ------------------------------------------

@jit
def rotation(q, o):
    """A(p) = (2 e0^2 - 1) I + 2 (e e^T + e0 ẽ) of the Euler parameters q[o:o+4] (section 2.1)."""
    A = np.empty((3, 3))
    rotation_into(q, o, A)
    return A


@jit
def rotation_into(q, o, A):
    """A <- A(p) of the Euler parameters q[o:o+4], in place (no allocation)."""
    e0, e1, e2, e3 = q[o], q[o + 1], q[o + 2], q[o + 3]
    c = 2.0 * e0 * e0 - 1.0
    A[0, 0] = c + 2.0 * e1 * e1
    A[1, 1] = c + 2.0 * e2 * e2
    A[2, 2] = c + 2.0 * e3 * e3
    A[0, 1] = 2.0 * (e1 * e2 - e0 * e3)
    A[1, 0] = 2.0 * (e1 * e2 + e0 * e3)
    A[0, 2] = 2.0 * (e1 * e3 + e0 * e2)
    A[2, 0] = 2.0 * (e1 * e3 - e0 * e2)
    A[1, 2] = 2.0 * (e2 * e3 - e0 * e1)
    A[2, 1] = 2.0 * (e2 * e3 + e0 * e1)


@jit
def das_dp(q, o, s):
    """∂(A(p) s')/∂p for p = q[o:o+4] (3 x 4): exact derivative of the polynomial A(p)."""
    e0, e1, e2, e3 = q[o], q[o + 1], q[o + 2], q[o + 3]
    out = np.empty((3, 4))
    # ∂/∂e0 = 2 (2 e0 s' + e × s')
    out[0, 0] = 2.0 * (2.0 * e0 * s[0] + e2 * s[2] - e3 * s[1])
    out[1, 0] = 2.0 * (2.0 * e0 * s[1] + e3 * s[0] - e1 * s[2])
    out[2, 0] = 2.0 * (2.0 * e0 * s[2] + e1 * s[1] - e2 * s[0])
    # ∂/∂e = 2 ((e·s') I + e s'^T - e0 s̃')
    es = e1 * s[0] + e2 * s[1] + e3 * s[2]
    e = (e1, e2, e3)
    for i in range(3):
        for j in range(3):
            v = e[i] * s[j]
            if i == j:
                v += es
            out[i, 1 + j] = 2.0 * v
    out[0, 2] -= 2.0 * e0 * (-s[2])
    out[0, 3] -= 2.0 * e0 * s[1]
    out[1, 1] -= 2.0 * e0 * s[2]
    out[1, 3] -= 2.0 * e0 * (-s[0])
    out[2, 1] -= 2.0 * e0 * (-s[1])
    out[2, 2] -= 2.0 * e0 * s[0]
    return out


@jit
def leg_residual(q, k, length, joints, out):
    """Leg k's 12 joint constraints (eqs. 3-8) and its driving constraint (eq. 10) -> out[0:13]."""
    leg_residual_with_rotations(q, k, length, joints, rotation(q, 3),
                                rotation(q, 7 * (1 + 2 * k) + 3), rotation(q, 7 * (2 + 2 * k) + 3),
                                out)


@jit
def leg_residual_with_rotations(q, k, length, joints, Ab, Al, Au, out):
    """:func:`leg_residual` with the rotation matrices of ring_b and leg k's links given."""
    a, ha, sb, cl, cu = joints
    ob = 0
    ol = 7 * (1 + 2 * k)
    ou = 7 * (2 + 2 * k)
    for i in range(3):
        s_b = Ab[i, 0] * sb[k, 0] + Ab[i, 1] * sb[k, 1] + Ab[i, 2] * sb[k, 2]
        out[i] = q[ou + i] + Au[i, 2] * cu - q[ob + i] - s_b
        out[3 + i] = q[ol + i] - Al[i, 2] * cl - a[k, i]
    out[6] = ha[k, 0] * Al[0, 1] + ha[k, 1] * Al[1, 1] + ha[k, 2] * Al[2, 1]
    d = (q[ou] + Au[0, 2] * cu - q[ol] + Al[0, 2] * cl,
         q[ou + 1] + Au[1, 2] * cu - q[ol + 1] + Al[1, 2] * cl,
         q[ou + 2] + Au[2, 2] * cu - q[ol + 2] + Al[2, 2] * cl)
    f0 = 0.0
    f1 = 0.0
    g0 = 0.0
    g1 = 0.0
    fg = 0.0
    hd = 0.0
    for i in range(3):
        f0 += Al[i, 0] * Au[i, 2]
        f1 += Al[i, 1] * Au[i, 2]
        g0 += Al[i, 0] * d[i]
        g1 += Al[i, 1] * d[i]
        fg += Al[i, 0] * Au[i, 1]
        hd += Al[i, 2] * d[i]
    out[7] = f0
    out[8] = f1
    out[9] = g0
    out[10] = g1
    out[11] = fg
    out[12] = hd - length


@jit
def leg_jacobian(q, k, joints, out):
    """∂/∂q of leg k's 13 rows (12 joint + driving); out (13, 21), columns [q_b, q_l, q_u]."""
    ha, sb, cl, cu = joints.ha, joints.sb, joints.cl, joints.cu
    ob = 0
    ol = 7 * (1 + 2 * k)
    ou = 7 * (2 + 2 * k)
    out[:, :] = 0.0
    Al = rotation(q, ol + 3)
    Au = rotation(q, ou + 3)
    sbk = np.empty(3)
    for i in range(3):
        sbk[i] = sb[k, i]
    ex = np.array([1.0, 0.0, 0.0])
    ey = np.array([0.0, 1.0, 0.0])
    ez = np.array([0.0, 0.0, 1.0])
    s_l = np.array([0.0, 0.0, -cl])
    s_u = np.array([0.0, 0.0, cu])
    Bb = das_dp(q, ob + 3, sbk)
    Bl_s = das_dp(q, ol + 3, s_l)
    Bu_s = das_dp(q, ou + 3, s_u)
    Bl_x = das_dp(q, ol + 3, ex)
    Bl_y = das_dp(q, ol + 3, ey)
    Bl_z = das_dp(q, ol + 3, ez)
    Bu_y = das_dp(q, ou + 3, ey)
    Bu_z = das_dp(q, ou + 3, ez)
    d = np.empty(3)
    for i in range(3):
        d[i] = q[ou + i] + Au[i, 2] * cu - q[ol + i] + Al[i, 2] * cl
    for i in range(3):
        # spherical (eq. 3)
        out[i, 14 + i] = 1.0
        out[i, i] = -1.0
        for j in range(4):
            out[i, 17 + j] = Bu_s[i, j]
            out[i, 3 + j] = -Bb[i, j]
        # universal, spherical part (eq. 4)
        out[3 + i, 7 + i] = 1.0
        for j in range(4):
            out[3 + i, 10 + j] = Bl_s[i, j]
    for j in range(4):
        v6 = 0.0
        v7l = 0.0
        v7u = 0.0
        v8l = 0.0
        v8u = 0.0
        v9 = 0.0
        v10 = 0.0
        v11l = 0.0
        v11u = 0.0
        v12 = 0.0
        w9 = 0.0
        w10 = 0.0
        w12 = 0.0
        for i in range(3):
            v6 += ha[k, i] * Bl_y[i, j]
            v7l += Au[i, 2] * Bl_x[i, j]
            v7u += Al[i, 0] * Bu_z[i, j]
            v8l += Au[i, 2] * Bl_y[i, j]
            v8u += Al[i, 1] * Bu_z[i, j]
            v9 += d[i] * Bl_x[i, j] - Al[i, 0] * Bl_s[i, j]
            v10 += d[i] * Bl_y[i, j] - Al[i, 1] * Bl_s[i, j]
            v12 += d[i] * Bl_z[i, j] - Al[i, 2] * Bl_s[i, j]
            w9 += Al[i, 0] * Bu_s[i, j]
            w10 += Al[i, 1] * Bu_s[i, j]
            w12 += Al[i, 2] * Bu_s[i, j]
            v11l += Au[i, 1] * Bl_x[i, j]
            v11u += Al[i, 0] * Bu_y[i, j]
        out[6, 10 + j] = v6
        out[7, 10 + j] = v7l
        out[7, 17 + j] = v7u
        out[8, 10 + j] = v8l
        out[8, 17 + j] = v8u
        out[9, 10 + j] = v9
        out[9, 17 + j] = w9
        out[10, 10 + j] = v10
        out[10, 17 + j] = w10
        out[11, 10 + j] = v11l
        out[11, 17 + j] = v11u
        out[12, 10 + j] = v12
        out[12, 17 + j] = w12
    for i in range(3):
        out[9, 14 + i] = Al[i, 0]
        out[9, 7 + i] = -Al[i, 0]
        out[10, 14 + i] = Al[i, 1]
        out[10, 7 + i] = -Al[i, 1]
        out[12, 14 + i] = Al[i, 2]
        out[12, 7 + i] = -Al[i, 2]


@jit
def all_constraints(q, lengths, joints):
    """Φ(q) of eq. 2 (91,): 72 joint, 6 driving, 13 normalisation constraints."""
    phi = np.empty(91)
    buf = np.empty(13)
    for k in range(6):
        leg_residual(q, k, lengths[k], joints, buf)
        phi[12 * k:12 * k + 12] = buf[:12]
        phi[72 + k] = buf[12]
    for b in range(13):
        o = 7 * b + 3
        phi[78 + b] = q[o] ** 2 + q[o + 1] ** 2 + q[o + 2] ** 2 + q[o + 3] ** 2 - 1.0
    return phi


@jit
def all_jacobian(q, joints):
    """Φ_q of eq. 2, dense (91, 91)."""
    J = np.zeros((91, 91))
    buf = np.empty((13, 21))
    for k in range(6):
        leg_jacobian(q, k, joints, buf)
        cols = (0, 7 * (1 + 2 * k), 7 * (2 + 2 * k))
        for blk in range(3):
            c0 = cols[blk]
            for j in range(7):
                for i in range(12):
                    J[12 * k + i, c0 + j] = buf[i, 7 * blk + j]
                J[72 + k, c0 + j] = buf[12, 7 * blk + j]
    for b in range(13):
        o = 7 * b + 3
        for j in range(4):
            J[78 + b, o + j] = 2.0 * q[o + j]
    return J
