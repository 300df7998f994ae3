"""Multibody model of an RRPS platform on 91 coordinates (paper section 2.2, eqs. 2-12).

Bodies (ring_a is ground): body 0 = ring_b, body 1 + 2k = lower link of leg k (universal joint
on ring_a), body 2 + 2k = upper link of leg k (spherical joint on ring_b). Each body has 7
coordinates q_b = [r_b, p_b]: r_b its centre of mass in ring_a's frame and p_b = (e0, e1, e2, e3)
its Euler parameters, so q has 13 x 7 = 91 entries (body b at q[7b:7b+7]). Body frames sit at
the centre of mass; a leg link's body z axis is along the leg and both links of a leg share one
rotation (``rrps_kinematics.inverse.lower_link_rotations``).

Constraints (eq. 2), Φ(q) = [Φ^K (72); Φ^D (6); Φ^P (13)]; rows 12k .. 12k+11 belong to leg k:

* 0-2   spherical joint, upper link - ring_b (eq. 3): r_u + A_u s'_u - r_b - A_b s'_b = 0
* 3-5   universal joint, ring_a - lower link, its spherical part (eq. 4): r_l + A_l s'_l - a_k = 0
* 6     universal joint, dot-1 of its two axes (eq. 5): h_k^T A_l y' = 0, h_k the axis fixed in
        ring_a (x of ``universal_joint_frames``), y' the cross's second axis in the link
* 7-8   translational joint, axes parallel (eq. 6): f_l^T h_u = 0, g_l^T h_u = 0
* 9-10  translational joint, common axis (eq. 7): f_l^T d = 0, g_l^T d = 0
* 11    translational joint, no relative spin (eq. 8): f_l^T g_u = 0
* 72+k  driving constraint (eq. 10): h_l^T d - L_k = 0
* 78+b  Euler-parameter normalisation (eq. 9): p_b^T p_b - 1 = 0

with f, g, h the body x, y, z axes, s'_l = (0, 0, -c_l) the universal-joint centre in the lower
link, s'_u = (0, 0, c_u) the spherical-joint centre in the upper link, s'_b the spherical-joint
centre in ring_b's com frame and d = r_u + A_u s'_u - r_l - A_l s'_l the leg vector between the
joint centres, so the driving constraint sets the actuator length exactly. Eq. 8's second
vector is the upper link's y axis: orthogonal to f_l when assembled, as eq. 8 requires.

Φ_q is analytic (exact derivatives of the polynomial A(p)), compiled with numba (plain Python
with ``RRPS_NUMBA=0``, see :mod:`.backend`), and has 718
structural nonzeros of 8281 (``jacobian(q, sparse=True)`` gives it as scipy CSC). Newton's
linear solve (eq. 11) exploits that structure by default: each leg's 15 rows touch only its 14
link coordinates and ring_b's 7, so eliminating the link unknowns per leg leaves a 7 x 7 system
(:func:`structured_solve`); SuperLU on the CSC matrix and dense LAPACK are the alternatives.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from .backend import jit
from .errors import SingularPoseError
from .forward import check_lengths
from .geometry import RobotGeometry
from .inverse import inverse_kinematics, pose_arrays, universal_joint_frames
from .rotations import (
    euler_parameters_to_quat_xyzw,
    matrix_to_euler_parameters,
    normalize_quat,
    quat_xyzw_to_euler_parameters,
    quat_xyzw_to_matrix,
)

__all__ = [
    'N_BODIES',
    'N_CONSTRAINTS',
    'N_COORDINATES',
    'N_DRIVING',
    'N_JOINT_CONSTRAINTS',
    'JointGeometry',
    'MultibodyModel',
    'MultibodyDKResult',
    'body_slice',
    'gauss_eliminate',
    'leg_jacobian',
    'leg_residual',
    'leg_residual_with_rotations',
    'lower_link_body',
    'rotation',
    'rotation_into',
    'structured_solve',
    'upper_link_body',
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
    """The joint data of eqs. 3-10, one typed bundle for the compiled kernels.

    ``a`` (6, 3): universal-joint centres a_k in ring_a's frame; ``ha`` (6, 3): each universal
    joint's axis h_k fixed in ring_a; ``sb`` (6, 3): the spherical-joint centres s'_b in ring_b's
    com frame; ``cl``, ``cu``: distances of the lower link's com from the universal joint and of
    the upper link's com from the spherical joint [m] (s'_l = (0, 0, -c_l), s'_u = (0, 0, c_u)).
    """

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


@jit
def gauss_eliminate(A, nrow, ncol_pivot, ncol):
    """Gaussian elimination with partial pivoting of A[:nrow, :ncol] on its first ncol_pivot
    columns (in place); returns (ok, flops)."""
    flops = 0
    for j in range(ncol_pivot):
        p = j
        big = abs(A[j, j])
        for i in range(j + 1, nrow):
            if abs(A[i, j]) > big:
                big = abs(A[i, j])
                p = i
        if big == 0.0:
            return False, flops
        if p != j:
            for m in range(ncol):
                tmp = A[j, m]
                A[j, m] = A[p, m]
                A[p, m] = tmp
        inv = 1.0 / A[j, j]
        flops += 1
        for i in range(j + 1, nrow):
            f = A[i, j] * inv
            A[i, j] = 0.0
            if f != 0.0:
                for m in range(j + 1, ncol):
                    A[i, m] -= f * A[j, m]
                flops += 1 + 2 * (ncol - j - 1)
    return True, flops


@jit
def structured_solve(J, rhs):
    """Solve Φ_q Δq = rhs (91) by the robot's structure; returns (ok, Δq, flops).

    Leg k's 15 rows (12 joint, driving, 2 normalisations) touch only its 14 link coordinates and
    ring_b's 7. Eliminating the 14 link unknowns from those rows (Gaussian elimination with
    partial pivoting on the 15 x 22 block [A_k | C_k | rhs_k]) leaves one equation in ring_b's
    coordinates per leg; with ring_b's normalisation that is a 7 x 7 system. Back-substitution
    then gives each leg's 14 unknowns. ``flops`` counts every multiply, add and division done.
    """
    dq = np.zeros(91)
    U = np.empty((6, 15, 22))
    S = np.empty((7, 8))
    flops = 0
    for k in range(6):
        c0 = 7 * (1 + 2 * k)
        rows = np.empty(15, dtype=np.int64)
        for i in range(12):
            rows[i] = 12 * k + i
        rows[12] = 72 + k
        rows[13] = 78 + 1 + 2 * k
        rows[14] = 78 + 2 + 2 * k
        for i in range(15):
            r = rows[i]
            for j in range(14):
                U[k, i, j] = J[r, c0 + j]
            for j in range(7):
                U[k, i, 14 + j] = J[r, j]
            U[k, i, 21] = rhs[r]
        ok, f = gauss_eliminate(U[k], 15, 14, 22)
        flops += f
        if not ok:
            return False, dq, flops
        for j in range(8):
            S[k, j] = U[k, 14, 14 + j]
    for j in range(7):
        S[6, j] = J[78, j]
    S[6, 7] = rhs[78]
    ok, f = gauss_eliminate(S, 7, 7, 8)
    flops += f
    if not ok:
        return False, dq, flops
    for i in range(6, -1, -1):
        s = S[i, 7]
        for m in range(i + 1, 7):
            s -= S[i, m] * dq[m]
        dq[i] = s / S[i, i]
        flops += 2 * (6 - i) + 1
    for k in range(6):
        c0 = 7 * (1 + 2 * k)
        for i in range(13, -1, -1):
            s = U[k, i, 21]
            for m in range(7):
                s -= U[k, i, 14 + m] * dq[m]
            for m in range(i + 1, 14):
                s -= U[k, i, m] * dq[c0 + m]
            dq[c0 + i] = s / U[k, i, i]
            flops += 2 * 7 + 2 * (13 - i) + 1
    return True, dq, flops


# --- the model ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class MultibodyDKResult:
    """Direct kinematics on the 91 coordinates (eqs. 11-12).

    ``q`` the solution, ``position``/``quaternion_xyzw`` ring_b's pose a_T_b extracted from it,
    ``residual`` max |Φ| at the end, ``iterations`` Newton steps taken, ``flops`` the operation
    count of :meth:`MultibodyModel.direct_kinematics`'s flop model, ``seconds`` wall time.
    """

    q: np.ndarray
    position: np.ndarray
    quaternion_xyzw: np.ndarray
    converged: bool
    iterations: int
    residual: float
    flops: int
    seconds: float


class MultibodyModel:
    """The 13-body, 91-coordinate model of one robot (see the module docstring)."""

    def __init__(self, geometry: RobotGeometry):
        self.geometry = geometry
        self.ring_b_com = np.asarray(geometry.ring_b_body.com, dtype=float)
        self.joints = JointGeometry(
            a=np.ascontiguousarray(geometry.ring_a_anchors, dtype=float),
            ha=np.ascontiguousarray(universal_joint_frames(geometry)[:, :, 0]),
            sb=np.ascontiguousarray(geometry.ring_b_anchors - self.ring_b_com),
            cl=float(geometry.lower_link.com_from_joint),
            cu=float(geometry.upper_link.com_from_joint))

    @cached_property
    def _sparsity(self) -> scipy.sparse.csc_matrix:
        """Structural nonzeros of Φ_q: every entry a kernel writes, at home and a generic pose
        (found on first use: only the sparse Jacobian and solver need them)."""
        pattern = all_jacobian(self.coordinates_from_pose(self.geometry.home_position,
                                                          self.geometry.home_quaternion_xyzw),
                               self.joints)
        q_rand = np.random.default_rng(0).normal(size=91)
        mask = (pattern != 0) | (all_jacobian(q_rand, self.joints) != 0)
        return scipy.sparse.csc_matrix(mask.astype(float))

    @cached_property
    def _entries(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the structural nonzeros, in CSC order."""
        return (self._sparsity.indices.copy(),
                np.repeat(np.arange(91), np.diff(self._sparsity.indptr)))

    # --- coordinates <-> pose ---

    def coordinates_from_pose(self, position, quaternion_xyzw) -> np.ndarray:
        """Consistent q (91,) for ring_b at a_T_b: every joint constraint satisfied exactly."""
        p, quat = pose_arrays(position, quaternion_xyzw)
        if p.ndim != 1:
            raise ValueError('coordinates_from_pose takes a single pose')
        quat = normalize_quat(quat)
        ik = inverse_kinematics(self.geometry, p, quat)
        if np.any(ik.lengths < 1e-9):
            raise SingularPoseError('singular pose: a leg has zero length')
        q = np.empty(91)
        Rb = quat_xyzw_to_matrix(quat)
        q[0:3] = p + Rb @ self.ring_b_com
        q[3:7] = quat_xyzw_to_euler_parameters(quat)
        p_links = matrix_to_euler_parameters(ik.lower_link_rotations)
        u = ik.unit_vectors
        for k in range(6):
            ol, ou = 7 * lower_link_body(k), 7 * upper_link_body(k)
            q[ol:ol + 3] = self.joints.a[k] + self.joints.cl * u[k]
            q[ol + 3:ol + 7] = p_links[k]
            q[ou:ou + 3] = ik.ring_b_anchors_in_a[k] - self.joints.cu * u[k]
            q[ou + 3:ou + 7] = p_links[k]
        return q

    def pose_from_coordinates(self, q) -> tuple[np.ndarray, np.ndarray]:
        """ring_b's (position, quaternion_xyzw) in ring_a's frame from q."""
        q = self._check_q(q)
        quat = normalize_quat(euler_parameters_to_quat_xyzw(q[3:7]))
        return q[0:3] - quat_xyzw_to_matrix(quat) @ self.ring_b_com, quat

    def lengths(self, q) -> np.ndarray:
        """Actuator lengths h_l^T d (eq. 10 without C) of q."""
        return self.constraints(q, np.zeros(6))[72:78]

    # --- constraints and Jacobian ---

    def constraints(self, q, lengths) -> np.ndarray:
        """Φ(q) of eq. 2, shape (91,); lengths (6,) enter the driving constraints."""
        q = self._check_q(q)
        L = check_lengths(lengths, batch=False)
        return all_constraints(q, L, self.joints)

    def jacobian(self, q, *, sparse: bool = False):
        """Analytic Φ_q (91 x 91), dense ndarray or scipy.sparse CSC (structural nonzeros)."""
        q = self._check_q(q)
        J = all_jacobian(q, self.joints)
        if not sparse:
            return J
        return scipy.sparse.csc_matrix((J[self._entries], self._sparsity.indices,
                                        self._sparsity.indptr), shape=(91, 91))

    @property
    def jacobian_nonzeros(self) -> int:
        """Structural nonzeros of Φ_q."""
        return int(self._sparsity.nnz)

    # --- direct kinematics ---

    def direct_kinematics(self, lengths, q_seed=None, *, tolerance: float = 1e-12,
                          max_iterations: int = 30, solver: str = 'structured') -> MultibodyDKResult:
        """Newton-Raphson Φ_q Δq = -Φ, q <- q + Δq (eqs. 11-12) from a seed (default: home).

        Flop model per iteration: residual (6 legs x FLOPS_LEG_RESIDUAL + 13 normalisations),
        Jacobian (6 x FLOPS_LEG_JACOBIAN + 13 x 4), the linear solve and the 91-term update.
        The solve counts, for ``solver='structured'`` (the default, :func:`structured_solve`:
        per-leg elimination and a 7 x 7 ring_b system), every operation it does; for
        ``solver='sparse'`` (SuperLU on the CSC Φ_q), the right-looking
        LU work Σ_k (l_k + 2 l_k u_k) with l_k, u_k the off-diagonal nonzeros of column k of L
        and row k of U, plus 2 (nnz(L) + nnz(U)) for the triangular solves; for
        ``solver='dense'`` (LAPACK), 2/3 n^3 + 2 n^2 with n = 91. A final residual evaluation is
        counted too. Never raises on non-convergence; the result says so.
        """
        if solver not in ('structured', 'sparse', 'dense'):
            raise ValueError(f"solver must be 'structured', 'sparse' or 'dense', got {solver!r}")
        L = check_lengths(lengths, batch=False)
        if q_seed is None:
            q_seed = self.coordinates_from_pose(self.geometry.home_position,
                                                self.geometry.home_quaternion_xyzw)
        q = self._check_q(q_seed).copy()
        t0 = time.perf_counter()
        residual_flops = 6 * FLOPS_LEG_RESIDUAL + 13 * FLOPS_NORMALISATION
        jacobian_flops = 6 * FLOPS_LEG_JACOBIAN + 13 * 4
        n = 91
        flops = 0
        iterations = 0
        converged = False
        phi = all_constraints(q, L, self.joints)
        flops += residual_flops
        res = float(np.max(np.abs(phi)))
        while True:
            if res <= tolerance:
                converged = True
                break
            if iterations >= max_iterations or not np.isfinite(res):
                break
            J = all_jacobian(q, self.joints)
            flops += jacobian_flops
            try:
                if solver == 'structured':
                    ok, dq, solve_flops = structured_solve(J, -phi)
                    if not ok:
                        break
                    flops += solve_flops
                elif solver == 'dense':
                    dq = np.linalg.solve(J, -phi)
                    flops += (2 * n**3) // 3 + 2 * n**2
                else:
                    Js = scipy.sparse.csc_matrix((J[self._entries],
                                                  self._sparsity.indices, self._sparsity.indptr),
                                                 shape=(n, n))
                    lu = scipy.sparse.linalg.splu(Js, permc_spec='COLAMD')
                    dq = lu.solve(-phi)
                    flops += _sparse_lu_flops(lu)
            except (np.linalg.LinAlgError, RuntimeError):
                break
            q += dq
            flops += n
            iterations += 1
            phi = all_constraints(q, L, self.joints)
            flops += residual_flops
            res = float(np.max(np.abs(phi)))
        seconds = time.perf_counter() - t0
        position, quat = self.pose_from_coordinates(q)
        return MultibodyDKResult(q=q, position=position, quaternion_xyzw=quat,
                                 converged=converged, iterations=iterations, residual=res,
                                 flops=int(flops), seconds=seconds)

    def _check_q(self, q) -> np.ndarray:
        q = np.ascontiguousarray(q, dtype=float)
        if q.shape != (91,):
            raise ValueError(f'q must have shape (91,), got {q.shape}')
        if not np.all(np.isfinite(q)):
            raise ValueError('q contains NaN or infinite values')
        return q


_LU_FLOPS_CACHE: dict[tuple, int] = {}


def _sparse_lu_flops(lu) -> int:
    """Right-looking LU work Σ_k (l_k + 2 l_k u_k) + triangular solves 2 (nnz(L) + nnz(U))."""
    Lf = lu.L.tocsc()
    Uf = lu.U.tocsr()
    key = (Lf.nnz, Uf.nnz, Lf.indptr.tobytes(), Uf.indptr.tobytes())
    if key not in _LU_FLOPS_CACHE:
        l_k = np.diff(Lf.indptr) - 1          # L has a unit diagonal stored
        u_k = np.diff(Uf.indptr) - 1
        _LU_FLOPS_CACHE[key] = int(np.sum(l_k + 2 * l_k * u_k) + 2 * (Lf.nnz + Uf.nnz))
    return _LU_FLOPS_CACHE[key]
