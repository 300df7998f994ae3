"""The kernels of IK lengths and Newton FK (eq. 1, §2.2), written once (:mod:`.backend`).

FK: residual L_i - l_i, Newton step J dx = f with J the inverse Jacobian, its angular columns
divided by the characteristic length (unit-consistent pivots); the rotation updated as
q <- exp(dtheta) (x) q; damped as :mod:`.forward` says (constants in :mod:`.newton_settings`).
"""

from __future__ import annotations

import math

from rrps_kinematics.backend import floats, jit, parallel_range
from rrps_kinematics.newton_settings import MAX_HALVINGS, MAX_ROTATION_STEP, PIVOT_TOLERANCE

__all__ = ['ik_lengths_batch', 'ik_lengths_parallel', 'fk_single', 'fk_solve', 'fk_batch',
           'fk_batch_parallel', 'quat_to_matrix', 'quotient', 'PARALLEL_ROWS']

#: Rows per task of the parallel batch kernels (the threads take the next task when done).
PARALLEL_ROWS = 256
_OPTIONS = dict(nogil=True, error_model='numpy')
#: The Newton iteration's parts are inlined into the solvers at numba's IR level: a call per
#: residual, step and update cost the batch FK kernel a tenth of its throughput (same run,
#: bit-identical results: 925 vs 1,025 k solves/s serial).
_INLINED = dict(_OPTIONS, inline='always')
prange = parallel_range()


@jit(**_OPTIONS)
def quotient(a, b):
    """a / b as IEEE 754 divides (inf or NaN for b = 0), compiled (numba's error model 'numpy') and
    interpreted alike (Python's float division raises there)."""
    if b != 0.0:
        return a / b
    if a != a or a == 0.0:
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


@jit(**_INLINED)
def quat_to_matrix(q, R):
    """R <- the rotation matrix of the unit quaternion q (x, y, z, w), row by row (9,), in place."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    R[0] = 1.0 - 2.0 * (y * y + z * z)
    R[1] = 2.0 * (x * y - z * w)
    R[2] = 2.0 * (x * z + y * w)
    R[3] = 2.0 * (x * y + z * w)
    R[4] = 1.0 - 2.0 * (x * x + z * z)
    R[5] = 2.0 * (y * z - x * w)
    R[6] = 2.0 * (x * z - y * w)
    R[7] = 2.0 * (y * z + x * w)
    R[8] = 1.0 - 2.0 * (x * x + y * y)


@jit(**_OPTIONS)
def ik_lengths_batch(A, B, P, Q, out):
    """out[n][i] = |P[n] + R(Q[n]) B[i] - A[i]| for unit quaternions Q (x, y, z, w) (eq. 1)."""
    R = floats(9)
    for n in range(len(P)):
        quat_to_matrix(Q[n], R)
        p = P[n]
        row = out[n]
        for i in range(6):
            a, b = A[i], B[i]
            s = 0.0
            for k in range(3):
                d = p[k] + R[3 * k] * b[0] + R[3 * k + 1] * b[1] + R[3 * k + 2] * b[2] - a[k]
                s += d * d
            row[i] = math.sqrt(s)


@jit(parallel=True, **_OPTIONS)
def ik_lengths_parallel(A, B, P, Q, out):
    """:func:`ik_lengths_batch` in runs of ``PARALLEL_ROWS`` rows on numba's threads: the same
    numbers (compiled only: the runs are views of the arrays)."""
    n = P.shape[0]
    for c in prange((n + PARALLEL_ROWS - 1) // PARALLEL_ROWS):
        start, stop = c * PARALLEL_ROWS, min(n, (c + 1) * PARALLEL_ROWS)
        ik_lengths_batch(A, B, P[start:stop], Q[start:stop], out[start:stop])


@jit(**_INLINED)
def _residual(A, B, L, p, q, R, rb, d, lengths, f):
    """A_c s'_i (rb) and the leg vectors d (18,: leg i at 3 i), lengths, residual f = L - l;
    returns (max |f|, sum f^2)."""
    quat_to_matrix(q, R)
    worst = 0.0
    ss = 0.0
    for i in range(6):
        a, b = A[i], B[i]
        s = 0.0
        for k in range(3):
            j = 3 * i + k
            rb[j] = R[3 * k] * b[0] + R[3 * k + 1] * b[1] + R[3 * k + 2] * b[2]
            d[j] = p[k] + rb[j] - a[k]
            s += d[j] * d[j]
        lengths[i] = math.sqrt(s)
        fi = L[i] - lengths[i]
        f[i] = fi
        if not abs(fi) <= worst:
            worst = abs(fi) if math.isfinite(fi) else math.inf  # NaN counts as infinite
        ss += fi * fi
    return worst, ss


@jit(**_INLINED)
def _solve_step(rb, d, lengths, f, inv_scale, M, dx):  # noqa: C901 - a kernel: flat loops for numba
    """Solve J dx = f by LU with partial pivoting on M (the 6 x 7 augmented matrix, row r at
    7 r); False when J is singular."""
    for i in range(6):
        li = lengths[i]
        if not li > 0.0:
            return False
        j, r = 3 * i, 7 * i
        ux, uy, uz = d[j] / li, d[j + 1] / li, d[j + 2] / li
        M[r] = ux
        M[r + 1] = uy
        M[r + 2] = uz
        M[r + 3] = (rb[j + 1] * uz - rb[j + 2] * uy) * inv_scale
        M[r + 4] = (rb[j + 2] * ux - rb[j] * uz) * inv_scale
        M[r + 5] = (rb[j] * uy - rb[j + 1] * ux) * inv_scale
        M[r + 6] = f[i]
    for c in range(6):
        piv = c
        best = abs(M[7 * c + c])
        for r in range(c + 1, 6):
            if abs(M[7 * r + c]) > best:
                best = abs(M[7 * r + c])
                piv = r
        if not best > PIVOT_TOLERANCE:
            return False
        top = 7 * c
        if piv != c:
            other = 7 * piv
            for k in range(c, 7):
                M[top + k], M[other + k] = M[other + k], M[top + k]
        for r in range(c + 1, 6):
            row = 7 * r
            m = M[row + c] / M[top + c]
            if m != 0.0:
                for k in range(c + 1, 7):
                    M[row + k] -= m * M[top + k]
    for c in range(5, -1, -1):
        row = 7 * c
        s = M[row + 6]
        for k in range(c + 1, 6):
            s -= M[row + k] * dx[k]
        dx[c] = s / M[row + c]
    for k in range(3, 6):
        dx[k] *= inv_scale
    for k in range(6):
        if not math.isfinite(dx[k]):
            return False
    return True


@jit(**_INLINED)
def _apply_step(p, q, dx, t, p_out, q_out):
    """p_out = p + t dx[:3]; q_out = exp(t dx[3:]) (x) q, normalised."""
    for k in range(3):
        p_out[k] = p[k] + t * dx[k]
    vx, vy, vz = t * dx[3], t * dx[4], t * dx[5]
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    if angle < 1e-6:
        s = 0.5 - angle * angle / 48.0
    else:
        s = math.sin(0.5 * angle) / angle
    ax, ay, az, aw = vx * s, vy * s, vz * s, math.cos(0.5 * angle)
    x, y, z, w = q[0], q[1], q[2], q[3]
    nx = aw * x + ax * w + ay * z - az * y
    ny = aw * y - ax * z + ay * w + az * x
    nz = aw * z + ax * y - ay * x + az * w
    nw = aw * w - ax * x - ay * y - az * z
    n = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    q_out[0] = nx / n
    q_out[1] = ny / n
    q_out[2] = nz / n
    q_out[3] = nw / n


@jit(**_INLINED)
def _fk(A, B, L, p, q, inv_scale, tolerance, max_iterations, work_p, work_q, R, rb, d, lengths, f,
        M, dx):
    """Newton FK in place on p, q; returns (converged, iterations, residual, singular)."""
    worst, ss = _residual(A, B, L, p, q, R, rb, d, lengths, f)
    it = 0
    while True:
        if worst <= tolerance:
            return True, it, worst, False
        if it >= max_iterations or not math.isfinite(ss):
            return False, it, worst, False
        if not _solve_step(rb, d, lengths, f, inv_scale, M, dx):
            return False, it, worst, True
        rot = math.sqrt(dx[3] * dx[3] + dx[4] * dx[4] + dx[5] * dx[5])
        t = 1.0
        if rot > MAX_ROTATION_STEP:
            t = MAX_ROTATION_STEP / rot
        accepted = False
        for _ in range(MAX_HALVINGS + 1):
            _apply_step(p, q, dx, t, work_p, work_q)
            w2, s2 = _residual(A, B, L, work_p, work_q, R, rb, d, lengths, f)
            if s2 < ss:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            # Restore the residual of the last accepted pose before reporting.
            worst, ss = _residual(A, B, L, p, q, R, rb, d, lengths, f)
            return False, it, worst, False
        for k in range(3):
            p[k] = work_p[k]
        for k in range(4):
            q[k] = work_q[k]
        worst, ss = w2, s2
        it += 1


@jit(**_OPTIONS)
def fk_single(A, B, L, p, q, inv_scale, tolerance, max_iterations):
    """One warm-started FK solve in place on p (3,) and q (4,)."""
    return _fk(A, B, L, p, q, inv_scale, tolerance, max_iterations, floats(3), floats(4),
               floats(9), floats(18), floats(18), floats(6), floats(6), floats(42), floats(6))


#: The one signature of the compiled :func:`fk_solve`: writable C-contiguous float64 vectors
#: (others raise TypeError instead of compiling a new specialisation in a real-time loop).
_FK_SOLVE_SIGNATURE = ('(float64[:, ::1], float64[:, ::1], float64[::1], float64[::1], float64[::1], '
                       'float64, float64, int64)')


@jit(signature=_FK_SOLVE_SIGNATURE, nogil=True)
def fk_solve(A, B, L, seed_p, seed_q, inv_scale, tolerance, max_iterations):
    """One FK solve from the seed (p (3,), q (4,), left unchanged), its input checked here:
    returns (ok, p, q, converged, iterations, residual, singular); ok is False (and the rest
    meaningless) for a wrong shape, NaN/inf in the lengths or the seed, or a zero quaternion,
    which the caller reports. q is normalised on entry and has w >= 0 on return."""
    p = floats(3)
    q = floats(4)
    if len(L) != 6 or len(seed_p) != 3 or len(seed_q) != 4:
        return False, p, q, False, 0, math.inf, False
    finite = 0.0
    for i in range(6):
        finite += 0.0 * L[i]  # NaN or inf anywhere makes it NaN
    norm2 = 0.0
    for k in range(4):
        q[k] = seed_q[k]
        norm2 += q[k] * q[k]
    for k in range(3):
        p[k] = seed_p[k]
        finite += 0.0 * p[k]
    norm = math.sqrt(norm2)
    if not (finite == 0.0 and math.isfinite(norm) and norm >= 1e-12):
        return False, p, q, False, 0, math.inf, False
    for k in range(4):
        q[k] /= norm
    c, it, res, sing = fk_single(A, B, L, p, q, inv_scale, tolerance, max_iterations)
    if q[3] < 0.0:
        for k in range(4):
            q[k] = -q[k]
    return True, p, q, c, it, res, sing


@jit(**_OPTIONS)
def fk_batch(A, B, L, P, Q, inv_scale, tolerance, max_iterations, converged, iterations, residual,
             singular):
    """FK for each row of L (N, 6) from seeds P (N, 3), Q (N, 4), in place (each q with w >= 0)."""
    work_p = floats(3)
    work_q = floats(4)
    R = floats(9)
    rb = floats(18)
    d = floats(18)
    lengths = floats(6)
    f = floats(6)
    M = floats(42)
    dx = floats(6)
    for n in range(len(L)):
        q = Q[n]
        c, it, res, sing = _fk(A, B, L[n], P[n], q, inv_scale, tolerance, max_iterations,
                               work_p, work_q, R, rb, d, lengths, f, M, dx)
        if q[3] < 0.0:
            for k in range(4):
                q[k] = -q[k]
        converged[n] = c
        iterations[n] = it
        residual[n] = res
        singular[n] = sing


@jit(parallel=True, **_OPTIONS)
def fk_batch_parallel(A, B, L, P, Q, inv_scale, tolerance, max_iterations, converged, iterations,
                      residual, singular):
    """:func:`fk_batch` in runs of ``PARALLEL_ROWS`` rows on numba's threads, each run solved by
    the serial kernel: the same numbers bit for bit (compiled only)."""
    n = L.shape[0]
    for c in prange((n + PARALLEL_ROWS - 1) // PARALLEL_ROWS):
        a, b = c * PARALLEL_ROWS, min(n, (c + 1) * PARALLEL_ROWS)
        fk_batch(A, B, L[a:b], P[a:b], Q[a:b], inv_scale, tolerance, max_iterations, converged[a:b],
                 iterations[a:b], residual[a:b], singular[a:b])
