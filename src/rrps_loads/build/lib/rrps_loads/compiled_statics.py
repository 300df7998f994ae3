"""One pose's statics as a compiled kernel: the actuator forces, the support's wrench and the
holding margin of :func:`rrps_loads.loads.static_solution` (paper eq. 19 at rest), for the teleop
load guards and the load-feasible workspace, without NumPy's per-call overhead::

    s = statics_arrays(geometry, Support.of('ring_a', world_q_support))
    margin = pose_statics(s, p, q, forces, wrench)   # forces (6,), wrench (6,) filled in place

The same equations as :mod:`rrps_loads.statics` and :mod:`rrps_loads.loads` (the reference; the
tests check both agree): with J the inverse Jacobian (eq. 1) and Q the wrench of everything the
free ring carries, J^T f = Q (ring_a supports: Q = -W_b; ring_b supports: Q = W_a), each leg's
weight split between its joints. The support's wrench follows from the supporting ring's
balance, the holding margin from :class:`rrps_description.loads.GripperCapacity`. Forces are
positive when they push the rings apart; the wrench is in the supporting ring's frame, its
moment about that ring's origin. Written with :func:`rrps_kinematics.backend.jit`: compiled by
numba when it is enabled, plain Python otherwise.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_kinematics.backend import jit
from rrps_loads.support import Support

__all__ = ['StaticsArrays', 'statics_arrays', 'pose_statics', 'grid_statics', 'NO_CAPACITY',
           'FRICTION', 'RATED_LIMITS']

#: ``StaticsArrays.capacity[0]``: the supporting ring has no holding capacity, a friction clamp,
#: or rated limits.
NO_CAPACITY, FRICTION, RATED_LIMITS = 0.0, 1.0, 2.0
#: A pivot of the elimination below this (relative to the largest entry) is a singular pose.
PIVOT_TOLERANCE = 1e-12


class StaticsArrays(NamedTuple):
    """A robot on one support, as contiguous arrays (the one robot argument of the kernels).

    ``anchors`` (2, 6, 3): a_i in ring_a, b_i in ring_b [m]; ``bodies`` (2, 4): mass [kg] and
    com [m] of ring_a and ring_b with what they carry; ``links`` (4,): lower and upper link mass
    [kg] and com from its joint [m]; ``world`` (4,): the supporting ring's index and gravity in
    its frame [m/s²]; ``tool`` (10,): the tool-centre point in ring_b [m], the tool force [N] and
    torque [N m] and 1 when they are fixed in the supporting ring's frame (a world-frame wrench),
    0 when in ring_b's; ``capacity`` (7,): the supporting gripper's model (``NO_CAPACITY``,
    ``FRICTION``: μN, r; ``RATED_LIMITS``: axial, shear, torque) and its contact point [m]."""

    anchors: np.ndarray
    bodies: np.ndarray
    links: np.ndarray
    world: np.ndarray
    tool: np.ndarray
    capacity: np.ndarray


def statics_arrays(geometry: RobotGeometry, support: Support) -> StaticsArrays:
    """The :class:`StaticsArrays` of ``geometry`` (its payload and tool wrench) on ``support``."""
    g = geometry
    bodies = np.array([[b.mass, *b.com] for b in (g.ring_a_body, g.ring_b_body)], dtype=float)
    lo, up = g.lower_link, g.upper_link
    tool = np.zeros(10)
    if g.tool is not None:
        tool[0:3] = g.tool.position
    w = g.tool_wrench
    if w is not None:
        if w.frame == 'tool':
            R = quat_xyzw_to_matrix(g.tool.quaternion_xyzw)
            tool[3:6], tool[6:9] = R @ w.force, R @ w.torque
        else:
            in_support = support.world_R_support.T
            tool[3:6], tool[6:9], tool[9] = in_support @ w.force, in_support @ w.torque, 1.0
    capacity = np.zeros(7)
    c = g.holding.get(support.ring)
    if c is not None:
        capacity[4:7] = c.contact
        if c.kind == 'friction':
            capacity[0:3] = FRICTION, c.friction * c.clamp_force, c.radius
        else:
            capacity[0:4] = RATED_LIMITS, c.axial_force, c.shear_force, c.torque
    return StaticsArrays(np.ascontiguousarray(np.stack([g.ring_a_anchors, g.ring_b_anchors]), dtype=float),
                         bodies, np.array([lo.mass, lo.com_from_joint, up.mass, up.com_from_joint], dtype=float),
                         np.array([float(support.index), *support.gravity_in_support]), tool, capacity)


@jit
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@jit
def _add_force(wrench, point, f0, f1, f2):
    """wrench (force, moment about the origin) += the force f applied at ``point``."""
    m = _cross(point[0], point[1], point[2], f0, f1, f2)
    for k in range(3):
        wrench[3 + k] += m[k]
    wrench[0] += f0
    wrench[1] += f1
    wrench[2] += f2


@jit
def _solve_transposed(J, load, f):
    """f <- the solution of J^T f = load (Gaussian elimination, partial pivoting); False when a
    pivot is below PIVOT_TOLERANCE of the largest entry (a singular pose)."""
    M = np.empty((6, 7))
    big = 0.0
    for r in range(6):
        for c in range(6):
            M[r, c] = J[c, r]
            big = max(big, abs(J[c, r]))
        M[r, 6] = load[r]
    if not big > 0.0:
        return False
    for c in range(6):
        pivot = c
        for r in range(c + 1, 6):
            if abs(M[r, c]) > abs(M[pivot, c]):
                pivot = r
        if not abs(M[pivot, c]) > PIVOT_TOLERANCE * big:
            return False
        if pivot != c:
            for k in range(7):
                M[c, k], M[pivot, k] = M[pivot, k], M[c, k]
        for r in range(c + 1, 6):
            m = M[r, c] / M[c, c]
            for k in range(c, 7):
                M[r, k] -= m * M[c, k]
    for r in range(5, -1, -1):
        s = M[r, 6]
        for k in range(r + 1, 6):
            s -= M[r, k] * f[k]
        f[r] = s / M[r, r]
    return True


@jit
def _holding_margin(capacity, w):
    """1 - the utilisation of the supporting gripper under the wrench w (loads.holding_margin);
    NaN without a capacity."""
    kind = capacity[0]
    if kind == NO_CAPACITY:
        return math.nan
    c0, c1, c2 = _cross(capacity[4], capacity[5], capacity[6], w[0], w[1], w[2])
    mx, my, mz = w[3] - c0, w[4] - c1, w[5] - c2
    if kind == FRICTION:
        return 1.0 - math.hypot(w[2], mz / capacity[2]) / capacity[1]
    use = max(max(-w[2], 0.0) / capacity[1], math.hypot(w[0], w[1]) / capacity[2])
    return 1.0 - max(use, math.sqrt(mx * mx + my * my + mz * mz) / capacity[3])


@jit
def pose_statics(s, p, q, forces, wrench):  # noqa: C901 - a compiled kernel: flat loops for numba
    """The robot ``s`` (:class:`StaticsArrays`) at rest with ring_b at (p, q) in ring_a (q unit,
    x, y, z, w): ``forces`` (6,) [N] and the support's ``wrench`` (6,) filled in place; returns
    the holding margin (NaN without a capacity). At a singular pose every output is NaN."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    R = np.empty((3, 3))
    R[0, 0], R[0, 1], R[0, 2] = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)
    R[1, 0], R[1, 1], R[1, 2] = 2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)
    R[2, 0], R[2, 1], R[2, 2] = 2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)
    A, B, bodies, links, tool = s.anchors[0], s.anchors[1], s.bodies, s.links, s.tool
    support = int(s.world[0])
    gs = s.world[1:4]
    g = np.empty(3)                    # gravity in ring_a
    fb = np.empty(3)                   # the tool force and torque in ring_b
    tb = np.empty(3)
    for k in range(3):
        g[k] = gs[k] if support == 0 else R[k, 0] * gs[0] + R[k, 1] * gs[1] + R[k, 2] * gs[2]
        if tool[9] > 0.0 and support == 0:    # a world-frame wrench, ring_b turned by R
            fb[k] = R[0, k] * tool[3] + R[1, k] * tool[4] + R[2, k] * tool[5]
            tb[k] = R[0, k] * tool[6] + R[1, k] * tool[7] + R[2, k] * tool[8]
        else:
            fb[k], tb[k] = tool[3 + k], tool[6 + k]
    b = np.empty((6, 3))               # R b_i: ring_b's anchors about its origin, in ring_a
    u = np.empty((6, 3))
    wb = np.empty((6, 3))              # each leg's weight at its spherical and universal joints
    wa = np.empty((6, 3))
    J = np.empty((6, 6))
    for i in range(6):
        d = np.empty(3)
        for k in range(3):
            b[i, k] = R[k, 0] * B[i, 0] + R[k, 1] * B[i, 1] + R[k, 2] * B[i, 2]
            d[k] = p[k] + b[i, k] - A[i, k]
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        ug = 0.0
        for k in range(3):
            u[i, k] = d[k] / length
            ug += u[i, k] * g[k]
        share = (links[0] * links[1] - links[2] * links[3]) / length
        for k in range(3):
            normal = g[k] - u[i, k] * ug
            wb[i, k] = links[2] * g[k] + share * normal
            wa[i, k] = links[0] * g[k] - share * normal
        J[i, 0], J[i, 1], J[i, 2] = u[i, 0], u[i, 1], u[i, 2]
        J[i, 3], J[i, 4], J[i, 5] = _cross(b[i, 0], b[i, 1], b[i, 2], u[i, 0], u[i, 1], u[i, 2])
    load = np.zeros(6)
    if support == 0:                   # J^T f = -W_b: ring_b, its legs' shares, the tool wrench
        m = bodies[1, 0]
        c = np.empty(3)
        tcp = np.empty(3)
        ft = np.empty(3)
        tt = np.empty(3)
        for k in range(3):
            c[k] = R[k, 0] * bodies[1, 1] + R[k, 1] * bodies[1, 2] + R[k, 2] * bodies[1, 3]
            tcp[k] = R[k, 0] * tool[0] + R[k, 1] * tool[1] + R[k, 2] * tool[2]
            ft[k] = R[k, 0] * fb[0] + R[k, 1] * fb[1] + R[k, 2] * fb[2]
            tt[k] = R[k, 0] * tb[0] + R[k, 1] * tb[1] + R[k, 2] * tb[2]
        moment = _cross(c[0], c[1], c[2], m * g[0], m * g[1], m * g[2])
        tool_moment = _cross(tcp[0], tcp[1], tcp[2], ft[0], ft[1], ft[2])
        for k in range(3):
            load[k] = -(m * g[k] + ft[k])
            load[3 + k] = -(moment[k] + tool_moment[k] + tt[k])
        for i in range(6):
            mi = _cross(b[i, 0], b[i, 1], b[i, 2], wb[i, 0], wb[i, 1], wb[i, 2])
            for k in range(3):
                load[k] -= wb[i, k]
                load[3 + k] -= mi[k]
    else:                              # J^T f = W_a: ring_a and its legs' shares about ring_b's origin
        m = bodies[0, 0]
        moment = _cross(bodies[0, 1] - p[0], bodies[0, 2] - p[1], bodies[0, 3] - p[2],
                        m * g[0], m * g[1], m * g[2])
        for k in range(3):
            load[k] = m * g[k]
            load[3 + k] = moment[k]
        for i in range(6):
            mi = _cross(A[i, 0] - p[0], A[i, 1] - p[1], A[i, 2] - p[2], wa[i, 0], wa[i, 1], wa[i, 2])
            for k in range(3):
                load[k] += wa[i, k]
                load[3 + k] += mi[k]
    if not _solve_transposed(J, load, forces):
        for k in range(6):
            forces[k] = math.nan
            wrench[k] = math.nan
        return math.nan
    for k in range(6):
        wrench[k] = 0.0
    if support == 0:                   # ring_a's balance: the universal joints f u - w', its weight
        m = bodies[0, 0]
        for i in range(6):
            _add_force(wrench, A[i], forces[i] * u[i, 0] - wa[i, 0], forces[i] * u[i, 1] - wa[i, 1],
                       forces[i] * u[i, 2] - wa[i, 2])
        mg = _cross(bodies[0, 1], bodies[0, 2], bodies[0, 3], gs[0], gs[1], gs[2])
        for k in range(3):
            wrench[k] -= m * gs[k]
            wrench[3 + k] -= m * mg[k]
    else:                              # ring_b's balance in its frame: the spherical joints -(f u + w)
        m = bodies[1, 0]
        for i in range(6):
            ra = np.empty(3)
            for k in range(3):
                ra[k] = -(forces[i] * u[i, k] + wb[i, k])
            _add_force(wrench, B[i], R[0, 0] * ra[0] + R[1, 0] * ra[1] + R[2, 0] * ra[2],
                       R[0, 1] * ra[0] + R[1, 1] * ra[1] + R[2, 1] * ra[2],
                       R[0, 2] * ra[0] + R[1, 2] * ra[1] + R[2, 2] * ra[2])
        mg = _cross(bodies[1, 1], bodies[1, 2], bodies[1, 3], gs[0], gs[1], gs[2])
        tm = _cross(tool[0], tool[1], tool[2], fb[0], fb[1], fb[2])
        for k in range(3):
            wrench[k] -= m * gs[k] + fb[k]
            wrench[3 + k] -= m * mg[k] + tm[k] + tb[k]
    return _holding_margin(s.capacity, wrench)


@jit
def grid_statics(s, points, q, max_force, out):
    """For each position ``points[n]`` (N, 3) at orientation ``q``: out[n] = (largest |f_i| /
    ``max_force``, holding margin). A singular pose gives NaN."""
    forces = np.empty(6)
    wrench = np.empty(6)
    for n in range(points.shape[0]):
        margin = pose_statics(s, points[n], q, forces, wrench)
        largest = 0.0
        for i in range(6):
            largest = max(largest, abs(forces[i]))
        out[n, 0] = largest / max_force if math.isfinite(forces[0]) else math.nan
        out[n, 1] = margin
