"""The statics kernels (eq. 19 at rest: J^T f = Q, J of eq. 1; derived in :mod:`rrps_loads.statics`),
written once: a pose's actuator forces, joint reactions, support wrench and holding margin.
``pose_statics(s, p, q, forces, wrench)`` fills forces (6,) [N, + pushes the rings apart] and the
wrench (6,) (supporting ring's frame, about its origin) in place and returns the margin. Compiled
by numba when enabled (:mod:`rrps_kinematics.backend`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.loads import GripperCapacity
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_kinematics.backend import floats, jit, matrix
from rrps_kinematics.compiled import quat_to_matrix, quotient
from rrps_loads.support import Support

__all__ = ['StaticsArrays', 'statics_arrays', 'capacity_array', 'pose_statics', 'grid_statics', 'statics_batch',
           'support_wrenches', 'holding_margins', 'NO_CAPACITY', 'FRICTION', 'RATED_LIMITS']

#: ``StaticsArrays.capacity[0]``: the supporting ring has no holding capacity, a friction clamp,
#: or rated limits.
NO_CAPACITY, FRICTION, RATED_LIMITS = 0.0, 1.0, 2.0
#: A pivot of the elimination below this (relative to the largest entry) is a singular pose.
PIVOT_TOLERANCE = 1e-12


class StaticsArrays(NamedTuple):
    """A robot on one support as contiguous arrays (the kernels' one robot argument), SI units,
    filled by :func:`statics_arrays`: anchors, ring and link masses and coms, the support and its
    gravity, the tool wrench and the supporting gripper's capacity."""

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
    return StaticsArrays(np.ascontiguousarray(np.stack([g.ring_a_anchors, g.ring_b_anchors]), dtype=float),
                         bodies, np.array([lo.mass, lo.com_from_joint, up.mass, up.com_from_joint], dtype=float),
                         np.array([float(support.index), *support.gravity_in_support]), tool,
                         capacity_array(g.holding.get(support.ring)))


def capacity_array(c: GripperCapacity | None) -> np.ndarray:
    """``StaticsArrays.capacity`` of a gripper (None: no capacity)."""
    capacity = np.zeros(7)
    if c is not None:
        capacity[4:7] = c.contact
        if c.kind == 'friction':
            capacity[0:3] = FRICTION, c.friction * c.clamp_force, c.radius
        else:
            capacity[0:4] = RATED_LIMITS, c.axial_force, c.shear_force, c.torque
    return capacity


@jit
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@jit
def _solve_transposed(J, load, f):
    """f <- the solution of J^T f = load (Gaussian elimination, partial pivoting); False when a
    pivot is below PIVOT_TOLERANCE of the largest entry (a singular pose)."""
    M = matrix(6, 7)
    big = 0.0
    for r in range(6):
        row = M[r]
        for c in range(6):
            row[c] = J[c][r]
            big = max(big, abs(J[c][r]))
        row[6] = load[r]
    if not big > 0.0:
        return False
    for c in range(6):
        pivot = c
        for r in range(c + 1, 6):
            if abs(M[r][c]) > abs(M[pivot][c]):
                pivot = r
        if not abs(M[pivot][c]) > PIVOT_TOLERANCE * big:
            return False
        top = M[c]
        if pivot != c:
            other = M[pivot]
            for k in range(7):
                top[k], other[k] = other[k], top[k]
        for r in range(c + 1, 6):
            row = M[r]
            m = row[c] / top[c]
            for k in range(c, 7):
                row[k] -= m * top[k]
    for r in range(5, -1, -1):
        row = M[r]
        x = row[6]
        for k in range(r + 1, 6):
            x -= row[k] * f[k]
        f[r] = x / row[r]
    return True


@jit
def _holding_margin(capacity, w):
    """1 - the utilisation of the gripper ``capacity`` under the wrench w the structure exerts on
    its ring (force, moment about the ring's origin, in its frame): 1 unloaded, 0 at its capacity,
    < 0 it slips or lets go; NaN without a capacity."""
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
def holding_margins(capacity, wrenches, out):
    """out[n] = the holding margin of ``capacity`` under ``wrenches[n]`` (N, 6)."""
    for n in range(len(out)):
        out[n] = _holding_margin(capacity, wrenches[n])


@jit
def _balance(s, reactions, wrench):
    """wrench <- the structure's wrench on the supporting ring from that ring's balance: the
    ``reactions`` (6, 3) its joints exert on the legs (universal joints of ring_a, spherical of
    ring_b), its weight and, for ring_b, the tool wrench; all in the supporting ring's frame."""
    support = int(s.world[0])
    anchors, body, gs, tool = s.anchors[support], s.bodies[support], s.world[1:4], s.tool
    for k in range(6):
        wrench[k] = 0.0
    for i in range(6):
        a, r = anchors[i], reactions[i]
        m = _cross(a[0], a[1], a[2], r[0], r[1], r[2])
        for k in range(3):
            wrench[k] += r[k]
            wrench[3 + k] += m[k]
    mass = body[0]
    mg = _cross(body[1], body[2], body[3], gs[0], gs[1], gs[2])
    for k in range(3):
        wrench[k] -= mass * gs[k]
        wrench[3 + k] -= mass * mg[k]
    if support == 1:                   # the tool wrench, in ring_b's frame
        tm = _cross(tool[0], tool[1], tool[2], tool[3], tool[4], tool[5])
        for k in range(3):
            wrench[k] -= tool[3 + k]
            wrench[3 + k] -= tm[k] + tool[6 + k]


@jit
def support_wrenches(s, reactions, out):
    """out[n] <- :func:`_balance` of ``reactions[n]`` (N, 6, 3)."""
    for n in range(len(out)):
        _balance(s, reactions[n], out[n])


@jit
def _statics_at(s, p, R, forces, universal, spherical, wrench, load):  # noqa: C901 - a kernel: flat loops
    """The robot ``s`` at rest with ring_b at (p, R) in ring_a: ``forces`` (6,) [N], the joint
    reactions on the legs ``universal`` and ``spherical`` (6, 3), the support's ``wrench`` and
    the ``load`` Q of J^T f = Q (ring_a's frame, about ring_b's origin), in place; returns the
    holding margin. At a singular pose the forces, reactions and wrench are NaN."""
    A, B, bodies, links, tool = s.anchors[0], s.anchors[1], s.bodies, s.links, s.tool
    support = int(s.world[0])
    gs = s.world[1:4]
    g = floats(3)                      # gravity in ring_a
    fb = floats(3)                     # the tool force and torque in ring_b
    tb = floats(3)
    for k in range(3):
        g[k] = gs[k] if support == 0 else R[3 * k] * gs[0] + R[3 * k + 1] * gs[1] + R[3 * k + 2] * gs[2]
        if tool[9] > 0.0 and support == 0:    # a world-frame wrench, ring_b turned by R
            fb[k] = R[k] * tool[3] + R[3 + k] * tool[4] + R[6 + k] * tool[5]
            tb[k] = R[k] * tool[6] + R[3 + k] * tool[7] + R[6 + k] * tool[8]
        else:
            fb[k], tb[k] = tool[3 + k], tool[6 + k]
    b = matrix(6, 3)                   # R b_i: ring_b's anchors about its origin, in ring_a
    u = matrix(6, 3)
    wb = matrix(6, 3)                  # each leg's weight at its spherical and universal joints
    wa = matrix(6, 3)
    J = matrix(6, 6)
    for i in range(6):
        bi, ui, Bi = b[i], u[i], B[i]
        for k in range(3):
            bi[k] = R[3 * k] * Bi[0] + R[3 * k + 1] * Bi[1] + R[3 * k + 2] * Bi[2]
            ui[k] = p[k] + bi[k] - A[i][k]
        length = math.sqrt(ui[0] * ui[0] + ui[1] * ui[1] + ui[2] * ui[2])
        ug = 0.0
        for k in range(3):
            ui[k] = quotient(ui[k], length)
            ug += ui[k] * g[k]
        share = quotient(links[0] * links[1] - links[2] * links[3], length)
        for k in range(3):
            normal = g[k] - ui[k] * ug
            wb[i][k] = links[2] * g[k] + share * normal
            wa[i][k] = links[0] * g[k] - share * normal
        row = J[i]
        row[0], row[1], row[2] = ui[0], ui[1], ui[2]
        row[3], row[4], row[5] = _cross(bi[0], bi[1], bi[2], ui[0], ui[1], ui[2])
    if support == 0:                   # J^T f = -W_b: ring_b, its legs' shares, the tool wrench
        body = bodies[1]
        m = body[0]
        c, tcp, ft, tt = floats(3), floats(3), floats(3), floats(3)
        for k in range(3):
            c[k] = R[3 * k] * body[1] + R[3 * k + 1] * body[2] + R[3 * k + 2] * body[3]
            tcp[k] = R[3 * k] * tool[0] + R[3 * k + 1] * tool[1] + R[3 * k + 2] * tool[2]
            ft[k] = R[3 * k] * fb[0] + R[3 * k + 1] * fb[1] + R[3 * k + 2] * fb[2]
            tt[k] = R[3 * k] * tb[0] + R[3 * k + 1] * tb[1] + R[3 * k + 2] * tb[2]
        moment = _cross(c[0], c[1], c[2], m * g[0], m * g[1], m * g[2])
        tool_moment = _cross(tcp[0], tcp[1], tcp[2], ft[0], ft[1], ft[2])
        for k in range(3):
            load[k] = -(m * g[k] + ft[k])
            load[3 + k] = -(moment[k] + tool_moment[k] + tt[k])
        for i in range(6):
            bi, wi = b[i], wb[i]
            mi = _cross(bi[0], bi[1], bi[2], wi[0], wi[1], wi[2])
            for k in range(3):
                load[k] -= wi[k]
                load[3 + k] -= mi[k]
    else:                              # J^T f = W_a: ring_a and its legs' shares about ring_b's origin
        body = bodies[0]
        m = body[0]
        moment = _cross(body[1] - p[0], body[2] - p[1], body[3] - p[2], m * g[0], m * g[1], m * g[2])
        for k in range(3):
            load[k] = m * g[k]
            load[3 + k] = moment[k]
        for i in range(6):
            a, wi = A[i], wa[i]
            mi = _cross(a[0] - p[0], a[1] - p[1], a[2] - p[2], wi[0], wi[1], wi[2])
            for k in range(3):
                load[k] += wi[k]
                load[3 + k] += mi[k]
    if not _solve_transposed(J, load, forces):
        for k in range(6):
            forces[k] = math.nan
            wrench[k] = math.nan
            for j in range(3):
                universal[k][j] = math.nan
                spherical[k][j] = math.nan
        return math.nan
    for i in range(6):                 # R_U = f u - w', R_S = -(f u + w), in the supporting ring's frame
        ui, ru, rs = u[i], universal[i], spherical[i]
        for k in range(3):
            ru[k] = forces[i] * ui[k] - wa[i][k]
            rs[k] = -(forces[i] * ui[k] + wb[i][k])
        if support == 1:
            x0, x1, x2 = ru[0], ru[1], ru[2]
            y0, y1, y2 = rs[0], rs[1], rs[2]
            for k in range(3):
                ru[k] = R[k] * x0 + R[3 + k] * x1 + R[6 + k] * x2
                rs[k] = R[k] * y0 + R[3 + k] * y1 + R[6 + k] * y2
    _balance(s, universal if support == 0 else spherical, wrench)
    return _holding_margin(s.capacity, wrench)


@jit
def pose_statics(s, p, q, forces, wrench):
    """The robot ``s`` (:class:`StaticsArrays`) at rest with ring_b at (p, q) in ring_a (q unit,
    x, y, z, w): ``forces`` (6,) [N] and the support's ``wrench`` (6,) filled in place; returns
    the holding margin (NaN without a capacity). At a singular pose every output is NaN."""
    R = floats(9)
    quat_to_matrix(q, R)
    return _statics_at(s, p, R, forces, matrix(6, 3), matrix(6, 3), wrench, floats(6))


@jit
def statics_batch(s, P, R, forces, universal, spherical, wrench, load, margin):
    """:func:`_statics_at` of the poses (P[n], R[n]) ((N, 3), (N, 9): rotations row by row), row n of
    each output."""
    for n in range(len(P)):
        margin[n] = _statics_at(s, P[n], R[n], forces[n], universal[n], spherical[n], wrench[n], load[n])


@jit
def grid_statics(s, points, q, max_force, out):
    """For each position ``points[n]`` (N, 3) at orientation ``q``: out[n] = (largest |f_i| /
    ``max_force``, holding margin). A singular pose gives NaN."""
    forces = floats(6)
    wrench = floats(6)
    for n in range(len(points)):
        margin = pose_statics(s, points[n], q, forces, wrench)
        largest = 0.0
        for i in range(6):
            largest = max(largest, abs(forces[i]))
        row = out[n]
        row[0] = largest / max_force if math.isfinite(forces[0]) else math.nan
        row[1] = margin
