"""The kernels of the teleop guards: one whole guarded step (:mod:`rrps_teleop.mapping`'s speed
limits, deceleration bands and refusal, with the FK or leg-speed scaling of its mode), with no
Python between its solves; the command in the flat buffer of :mod:`rrps_teleop.command_layout`.
Compiled by numba, or interpreted (:mod:`rrps_kinematics.backend`).
"""

from __future__ import annotations

import math

from rrps_kinematics.backend import floats, jit
from rrps_kinematics.compiled import fk_single
from rrps_kinematics.compiled_limits import pose_margin_arrays
from rrps_teleop.command_layout import (
    CHECK_CONDITIONING,
    CHECK_INTERFERENCE,
    CHECK_SPHERICAL,
    CHECK_STROKE,
    CHECK_UNIVERSAL,
    INTERFERENCE,
    INVERSE_CONDITION,
    LENGTHS,
    LIMIT_COLLISION_DECELERATE,
    LIMIT_COLLISION_HALT,
    LIMIT_NONE,
    LIMIT_SINGULARITY_DECELERATE,
    LIMIT_SINGULARITY_HALT,
    LIMIT_SPEED,
    QUATERNION,
    SPEED_TOLERANCE,
    SPHERICAL,
    STEP_ACCEPTED,
    STEP_FK_FAILED,
    STEP_REFUSED,
    STEP_UNCHANGED,
    STROKE,
    UNIVERSAL,
)

__all__ = ['evaluate_pose', 'guarded_joint_step', 'guarded_cartesian_step', 'mapped_pose', 'scaled_step',
           'interpolated_pose', 'rotation_vector']

#: FK of the candidate lengths: the defaults of :func:`rrps_kinematics.forward_kinematics`.
FK_TOLERANCE = 1e-12
FK_MAX_ITERATIONS = 30


@jit
def _canonical_quaternion(q):
    """q / |q| in place, in the sign of :func:`rrps_description.rotations.normalize_quat`."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for k in range(4):
        q[k] /= n
    lead = q[3]
    if lead == 0.0:
        for k in range(3):
            if q[k] != 0.0:
                lead = q[k]
                break
    if lead < 0.0:
        for k in range(4):
            q[k] = -q[k]


@jit
def _multiply(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product a ⊗ b of (x, y, z, w) quaternions, as four floats."""
    return (a3 * b0 + a0 * b3 + a1 * b2 - a2 * b1,
            a3 * b1 - a0 * b2 + a1 * b3 + a2 * b0,
            a3 * b2 + a0 * b1 - a1 * b0 + a2 * b3,
            a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2)


@jit
def _angle_between(a, b):
    """rotations.rotation_angle_between of two unit quaternions: 2 atan2(|e|, |e0|) of conj(a) b."""
    x, y, z, w = _multiply(-a[0], -a[1], -a[2], a[3], b[0], b[1], b[2], b[3])
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


@jit
def evaluate_pose(g, p, q, out):
    """out <- the command at pose (p, q): the pose, its IK lengths (eq. 1) and every margin."""
    for k in range(3):
        out[k] = p[k]
    for k in range(4):
        out[QUATERNION + k] = q[k]
    out[INVERSE_CONDITION] = pose_margin_arrays(
        g, out[0:3], out[QUATERNION:QUATERNION + 4], out[LENGTHS:LENGTHS + 6], out[STROKE:STROKE + 6],
        out[UNIVERSAL:UNIVERSAL + 6], out[SPHERICAL:SPHERICAL + 6], out[INTERFERENCE:INTERFERENCE + 15])


@jit
def _evaluate_lengths(g, inv_scale, prev, lengths, out):
    """out <- the command of leg lengths ``lengths``: FK warm-started at prev's pose, the margins
    there, and the commanded lengths. False when the FK does not converge."""
    p, q = floats(3), floats(4)
    for k in range(3):
        p[k] = prev[k]
    for k in range(4):
        q[k] = prev[QUATERNION + k]
    converged = fk_single(g.ring_a_anchors, g.ring_b_anchors, lengths, p, q, inv_scale, FK_TOLERANCE,
                          FK_MAX_ITERATIONS)[0]
    if not converged:
        return False
    if q[3] < 0.0:
        for k in range(4):
            q[k] = -q[k]
    evaluate_pose(g, p, q, out)
    for i in range(6):
        out[LENGTHS + i] = lengths[i]
    return True


@jit
def _minimum(buffer, start, n):
    value = buffer[start]
    for i in range(start + 1, start + n):
        value = min(value, buffer[i])
    return value


@jit
def _deceleration(before, after, slowdown, halt, collision_slowdown):
    """(step scale in [0, 1], LIMIT_*) near a singularity or interference, when the step approaches it."""
    factor, limit = 1.0, LIMIT_NONE
    c0, c1 = before[INVERSE_CONDITION], after[INVERSE_CONDITION]
    if c1 < c0 and c0 < slowdown:
        f = min(max((c0 - halt) / (slowdown - halt), 0.0), 1.0)
        if f < factor:
            factor = f
            limit = LIMIT_SINGULARITY_DECELERATE if f > 0.0 else LIMIT_SINGULARITY_HALT
    d0, d1 = _minimum(before, INTERFERENCE, 15), _minimum(after, INTERFERENCE, 15)
    if d1 < d0 and d0 < collision_slowdown:
        f = min(max(d0 / collision_slowdown, 0.0), 1.0)
        if f < factor:
            factor = f
            limit = LIMIT_COLLISION_DECELERATE if f > 0.0 else LIMIT_COLLISION_HALT
    return factor, limit


@jit
def _worse(new, old):
    """A margin that is negative (or NaN) and not better than before."""
    return not (new >= 0.0) and not (new >= old)


@jit
def _refusal(prev, cand, halt):
    """(CHECK_*, index) of the first margin the step breaks or worsens, (-1, -1) if none."""
    for check, start, n in ((CHECK_STROKE, STROKE, 6), (CHECK_UNIVERSAL, UNIVERSAL, 6),
                            (CHECK_SPHERICAL, SPHERICAL, 6), (CHECK_INTERFERENCE, INTERFERENCE, 15)):
        for i in range(start, start + n):
            if _worse(cand[i], prev[i]):
                return check, i - start
    if _worse(cand[INVERSE_CONDITION] - halt, prev[INVERSE_CONDITION] - halt):
        return CHECK_CONDITIONING, 0
    return -1, -1


@jit
def guarded_joint_step(g, inv_scale, prev, target, max_leg_step, slowdown, halt, collision_slowdown,
                       out):
    """Joint mode: the step from command ``prev`` towards leg lengths ``target``, guarded, into
    ``out``. Returns (STEP_*, LIMIT_*, CHECK_*, index): ``out`` is the new command when
    STEP_ACCEPTED. ``max_leg_step``: the largest |ΔL_i| of this step [m]."""
    dL = floats(6)
    largest = 0.0
    for i in range(6):
        dL[i] = target[i] - prev[LENGTHS + i]
        largest = max(largest, abs(dL[i]))
    if largest < 1e-12:
        return STEP_UNCHANGED, LIMIT_NONE, -1, -1
    fraction, limit = 1.0, LIMIT_NONE
    if largest > max_leg_step * (1.0 + SPEED_TOLERANCE):
        fraction, limit = max_leg_step / largest, LIMIT_SPEED
    lengths = floats(6)
    for i in range(6):
        lengths[i] = prev[LENGTHS + i] + fraction * dL[i]
    if not _evaluate_lengths(g, inv_scale, prev, lengths, out):
        return STEP_FK_FAILED, limit, -1, -1
    factor, slow = _deceleration(prev, out, slowdown, halt, collision_slowdown)
    if factor < 1.0:
        fraction *= factor
        limit = slow
        for i in range(6):
            lengths[i] = prev[LENGTHS + i] + fraction * dL[i]
        if not _evaluate_lengths(g, inv_scale, prev, lengths, out):
            return STEP_FK_FAILED, limit, -1, -1
    check, index = _refusal(prev, out, halt)
    if check >= 0:
        return STEP_REFUSED, limit, check, index
    return STEP_ACCEPTED, limit, -1, -1


@jit
def interpolated_pose(p0, q0, p1, rv, fraction, p, q):
    """p, q <- the pose a ``fraction`` of the way from (p0, q0) to (p1, exp(rv) ⊗ q0): straight
    line, constant-axis rotation; q canonical (w >= 0)."""
    for k in range(3):
        p[k] = p0[k] + fraction * (p1[k] - p0[k])
    vx, vy, vz = fraction * rv[0], fraction * rv[1], fraction * rv[2]
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    s = 0.5 - angle * angle / 48.0 if angle < 1e-6 else math.sin(0.5 * angle) / angle
    q[0], q[1], q[2], q[3] = _multiply(vx * s, vy * s, vz * s, math.cos(0.5 * angle), q0[0], q0[1], q0[2], q0[3])
    _canonical_quaternion(q)


@jit
def _pose_step(g, prev, p1, rv, fraction, out):
    """out <- the command a ``fraction`` of the way from prev's pose to (p1, exp(rv) ⊗ q_prev)."""
    p, q = floats(3), floats(4)
    interpolated_pose(prev[0:3], prev[QUATERNION:QUATERNION + 4], p1, rv, fraction, p, q)
    evaluate_pose(g, p, q, out)


@jit
def rotation_vector(q0, q1):
    """The rotation from orientation q0 to q1 (q1 = exp(rv) ⊗ q0) as a rotation vector (angle in
    [0, pi])."""
    x, y, z, w = _multiply(q1[0], q1[1], q1[2], q1[3], -q0[0], -q0[1], -q0[2], q0[3])
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 / max(w, 1e-300) if s < 1e-9 else 2.0 * math.atan2(s, w) / s
    rv = floats(3)
    rv[0], rv[1], rv[2] = x * k, y * k, z * k
    return rv


@jit
def scaled_step(g, inv_scale, prev, cand, factor, joint, halt, out):
    """out <- the command a ``factor`` of the way from command ``prev`` to command ``cand``:
    along the leg lengths (``joint``) or the pose, as the guarded steps scale theirs (the load
    guards' slow-down). Returns STEP_ACCEPTED, STEP_REFUSED (it breaks or worsens a kinematic
    margin) or STEP_FK_FAILED."""
    if joint:
        lengths = floats(6)
        for i in range(6):
            lengths[i] = prev[LENGTHS + i] + factor * (cand[LENGTHS + i] - prev[LENGTHS + i])
        if not _evaluate_lengths(g, inv_scale, prev, lengths, out):
            return STEP_FK_FAILED
    else:
        _pose_step(g, prev, cand[0:3], rotation_vector(prev[QUATERNION:QUATERNION + 4],
                                                       cand[QUATERNION:QUATERNION + 4]), factor, out)
    return STEP_REFUSED if _refusal(prev, out, halt)[0] >= 0 else STEP_ACCEPTED


@jit
def guarded_cartesian_step(g, prev, p1, q1, max_linear_step, max_angular_step, max_leg_step,
                           leg_iterations, slowdown, halt, collision_slowdown, out):
    """Cartesian mode: the step from command ``prev`` towards pose (p1, q1), guarded, into ``out``.
    Returns (STEP_*, LIMIT_*, CHECK_*, index) as :func:`guarded_joint_step`. Limits of this step:
    |Δp| <= max_linear_step [m], |Δθ| <= max_angular_step [rad], |ΔL_i| <= max_leg_step [m]."""
    dp = math.sqrt((p1[0] - prev[0]) ** 2 + (p1[1] - prev[1]) ** 2 + (p1[2] - prev[2]) ** 2)
    dth = _angle_between(prev[QUATERNION:QUATERNION + 4], q1)
    if dp < 1e-12 and dth < 1e-12:
        return STEP_UNCHANGED, LIMIT_NONE, -1, -1
    fraction, limit = 1.0, LIMIT_NONE
    bound = min(max_linear_step / dp if dp > 0.0 else math.inf,
                max_angular_step / dth if dth > 0.0 else math.inf)
    if bound < 1.0 - SPEED_TOLERANCE:
        fraction, limit = bound, LIMIT_SPEED
    rv = rotation_vector(prev[QUATERNION:QUATERNION + 4], q1)
    _pose_step(g, prev, p1, rv, fraction, out)
    for _ in range(leg_iterations):  # lengths are nearly linear in the fraction: 1-2 passes
        leg_step = 0.0
        for i in range(6):
            leg_step = max(leg_step, abs(out[LENGTHS + i] - prev[LENGTHS + i]))
        if leg_step <= max_leg_step * (1.0 + SPEED_TOLERANCE):
            break
        fraction *= max_leg_step / leg_step * (1.0 - 1e-9)
        limit = LIMIT_SPEED
        _pose_step(g, prev, p1, rv, fraction, out)
    factor, slow = _deceleration(prev, out, slowdown, halt, collision_slowdown)
    if factor < 1.0:
        fraction *= factor
        limit = slow
        _pose_step(g, prev, p1, rv, fraction, out)
    check, index = _refusal(prev, out, halt)
    if check >= 0:
        return STEP_REFUSED, limit, check, index
    return STEP_ACCEPTED, limit, -1, -1


@jit
def mapped_pose(pm, qm, pm0, qm0, ps0, qs0, scale, absolute, p_out, q_out):
    """The Cartesian map of ring_b (TeleopMapping.desired): p = ps0 + scale (pm - pm0);
    q = qm (absolute) or (qm ⊗ conj(qm0)) ⊗ qs0 (relative), normalised."""
    for k in range(3):
        p_out[k] = ps0[k] + scale * (pm[k] - pm0[k])
    if absolute:
        for k in range(4):
            q_out[k] = qm[k]
    else:
        r = _multiply(qm[0], qm[1], qm[2], qm[3], -qm0[0], -qm0[1], -qm0[2], qm0[3])
        q_out[0], q_out[1], q_out[2], q_out[3] = _multiply(r[0], r[1], r[2], r[3],
                                                           qs0[0], qs0[1], qs0[2], qs0[3])
    _canonical_quaternion(q_out)

