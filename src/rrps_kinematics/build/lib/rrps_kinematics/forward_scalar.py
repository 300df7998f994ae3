"""One warm-started FK solve on plain Python floats: the single call of the NumPy fallback.

The iterates of the compiled kernel (:func:`rrps_kinematics.compiled.fk_single`: residual of
eq. 1, Newton step J dx = f by LU with partial pivoting, multiplicative rotation update, damped
line search), written with the same operations in the same order on Python floats. For one pose
of six legs the interpreter's float arithmetic costs less than dispatching NumPy calls on
(6, 3) arrays, so without numba (``RRPS_NUMBA=0`` or ``backend='numpy'``) a single solve is
no slower than a plain NumPy Newton loop. Batches use the vectorised NumPy path of
:mod:`.forward`. Inputs are checked by the caller.
"""

from __future__ import annotations

import math

from rrps_kinematics.newton_settings import MAX_HALVINGS, MAX_ROTATION_STEP, PIVOT_TOLERANCE

__all__ = ['fk_python']


def _residual(A, B, L, p, q):
    """Leg vectors A_c s'_i and d_i, lengths, f = L - l, max |f| (NaN counts as inf), sum f^2."""
    x, y, z, w = q
    r00, r01, r02 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)
    r10, r11, r12 = 2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)
    r20, r21, r22 = 2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)
    p0, p1, p2 = p
    rb, d, lengths, f = [], [], [], []
    worst = 0.0
    ss = 0.0
    for (a0, a1, a2), (b0, b1, b2), Li in zip(A, B, L):
        c0 = r00 * b0 + r01 * b1 + r02 * b2
        c1 = r10 * b0 + r11 * b1 + r12 * b2
        c2 = r20 * b0 + r21 * b1 + r22 * b2
        d0, d1, d2 = p0 + c0 - a0, p1 + c1 - a1, p2 + c2 - a2
        length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        fi = Li - length
        if not abs(fi) <= worst:
            worst = abs(fi) if math.isfinite(fi) else math.inf
        ss += fi * fi
        rb.append((c0, c1, c2))
        d.append((d0, d1, d2))
        lengths.append(length)
        f.append(fi)
    return rb, d, lengths, f, worst, ss


def _solve_step(rb, d, lengths, f, inv_scale):
    """dx of J dx = f (angular part divided by the characteristic length twice, as the kernel),
    or None when J is singular."""
    M = []
    for (c0, c1, c2), (d0, d1, d2), li, fi in zip(rb, d, lengths, f):
        if not li > 0.0:
            return None
        ux, uy, uz = d0 / li, d1 / li, d2 / li
        M.append([ux, uy, uz, (c1 * uz - c2 * uy) * inv_scale, (c2 * ux - c0 * uz) * inv_scale,
                  (c0 * uy - c1 * ux) * inv_scale, fi])
    for c in range(6):
        piv = c
        best = abs(M[c][c])
        for r in range(c + 1, 6):
            if abs(M[r][c]) > best:
                best = abs(M[r][c])
                piv = r
        if not best > PIVOT_TOLERANCE:
            return None
        if piv != c:
            M[c], M[piv] = M[piv], M[c]
        top = M[c]
        for r in range(c + 1, 6):
            row = M[r]
            m = row[c] / top[c]
            if m != 0.0:
                for k in range(c + 1, 7):
                    row[k] -= m * top[k]
    dx = [0.0] * 6
    for c in range(5, -1, -1):
        row = M[c]
        s = row[6]
        for k in range(c + 1, 6):
            s -= row[k] * dx[k]
        dx[c] = s / row[c]
    for k in range(3, 6):
        dx[k] *= inv_scale
    if not all(math.isfinite(v) for v in dx):
        return None
    return dx


def _apply_step(p, q, dx, t):
    """(p + t dx[:3], exp(t dx[3:]) (x) q normalised)."""
    vx, vy, vz = t * dx[3], t * dx[4], t * dx[5]
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    s = 0.5 - angle * angle / 48.0 if angle < 1e-6 else math.sin(0.5 * angle) / angle
    ax, ay, az, aw = vx * s, vy * s, vz * s, math.cos(0.5 * angle)
    x, y, z, w = q
    nx = aw * x + ax * w + ay * z - az * y
    ny = aw * y - ax * z + ay * w + az * x
    nz = aw * z + ax * y - ay * x + az * w
    nw = aw * w - ax * x - ay * y - az * z
    n = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    return ((p[0] + t * dx[0], p[1] + t * dx[1], p[2] + t * dx[2]),
            (nx / n, ny / n, nz / n, nw / n))


def fk_python(A, B, L, p, q, inv_scale, tolerance, max_iterations):
    """Newton FK from the seed p (3,), unit q (4,) (sequences of floats; A, B: six (3,) rows).

    Returns (p, q, converged, iterations, residual, singular) like the compiled kernel.
    """
    rb, d, lengths, f, worst, ss = _residual(A, B, L, p, q)
    it = 0
    while True:
        if worst <= tolerance:
            return p, q, True, it, worst, False
        if it >= max_iterations or not math.isfinite(ss):
            return p, q, False, it, worst, False
        dx = _solve_step(rb, d, lengths, f, inv_scale)
        if dx is None:
            return p, q, False, it, worst, True
        rot = math.sqrt(dx[3] * dx[3] + dx[4] * dx[4] + dx[5] * dx[5])
        t = MAX_ROTATION_STEP / rot if rot > MAX_ROTATION_STEP else 1.0
        for _ in range(MAX_HALVINGS + 1):
            p2, q2 = _apply_step(p, q, dx, t)
            rb, d, lengths, f, w2, s2 = _residual(A, B, L, p2, q2)
            if s2 < ss:
                break
            t *= 0.5
        else:
            return p, q, False, it, _residual(A, B, L, p, q)[4], False
        p, q, worst, ss = p2, q2, w2, s2
        it += 1
