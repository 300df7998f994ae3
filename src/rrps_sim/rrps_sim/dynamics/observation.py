"""Compiled kernels of what is observed of a 13-body dynamics state (:mod:`.kernels` solves eq. 19):
each actuator's length and rate, the actuators' power, the constraint drift (eqs. 3-12) and the
Euler parameters' norm error, the ring's pose, and the kinetic and potential energy, in one pass
(:class:`~.bundles.Observations`). Compiled by numba like every :func:`~rrps_kinematics.backend.jit`
kernel, or run as Python with ``RRPS_NUMBA=0``.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import leg_residual_with_rotations, rotation_into
from rrps_sim.dynamics.bundles import Observation, Observations, workspace
from rrps_sim.dynamics.constraints import angular_velocity, cross3, dot3, matvec3, ring_b_grounded_residual

__all__ = ['actuator_power', 'drift_and_norm', 'leg_length_rate', 'observe', 'observe_into']


@jit
def leg_length_rate(q, v, k, joints, Ab, wb):
    """Actuator k's length and rate from the hub's state: S_k = r_h + A_h s'_k, L = |S_k - a_k|
    (the hub's joint centre to the ground's)."""
    a, sb = joints.a, joints.sb
    s = matvec3(Ab, (sb[k, 0], sb[k, 1], sb[k, 2]))
    ws = cross3(wb, s)
    d = (q[0] + s[0] - a[k, 0], q[1] + s[1] - a[k, 1], q[2] + s[2] - a[k, 2])
    n = math.sqrt(dot3(d, d))
    return n, (dot3(d, (v[0], v[1], v[2])) + dot3(d, ws)) / n


@jit
def actuator_power(q, v, forces, joints, Ab):
    """Σ f_k L̇_k [W] at a state, A_b = the hub's rotation."""
    wb = angular_velocity(Ab, v, 0)
    power = 0.0
    for k in range(6):
        power += forces[k] * leg_length_rate(q, v, k, joints, Ab, wb)[1]
    return power


@jit
def drift_and_norm(q, params, ws):
    """‖Φ^K‖ (2-norm of the 72 joint constraints) and max_b |p_b^T p_b - 1|."""
    A = ws.rotations
    for b in range(13):
        rotation_into(q, 7 * b + 3, A[b])
    res = ws.residual
    s = 0.0
    for k in range(6):
        leg_residual_with_rotations(q, k, 0.0, params.joints, A[0], A[1 + 2 * k], A[2 + 2 * k], res)
        if params.support == 1:
            ring_b_grounded_residual(q, k, params.joints, A[0], A[1 + 2 * k], A[2 + 2 * k], res)
        for i in range(12):
            s += res[i] * res[i]
    n = 0.0
    for b in range(13):
        o = 7 * b + 3
        n = max(n, abs(q[o] ** 2 + q[o + 1] ** 2 + q[o + 2] ** 2 + q[o + 3] ** 2 - 1.0))
    return math.sqrt(s), n


@jit
def observe_into(q, v, params, ws, out, row):
    """Everything reported about a state, in one pass, into row ``row`` of ``out``
    (:class:`Observations`)."""
    mass, inertia, gravity, com_b = params.mass, params.inertia, params.gravity, params.hub_com
    drift, norm_error = drift_and_norm(q, params, ws)
    n = math.sqrt(q[3] ** 2 + q[4] ** 2 + q[5] ** 2 + q[6] ** 2)
    euler = out.euler_parameters[row]
    for i in range(4):
        euler[i] = q[3 + i] / n
    Ab = ws.rotations[0]
    rotation_into(euler, 0, Ab)
    c = matvec3(Ab, (com_b[0], com_b[1], com_b[2]))
    for i in range(3):
        out.position[row, i] = q[i] - c[i]
    rotation_into(q, 3, Ab)
    wb = angular_velocity(Ab, v, 0)
    for k in range(6):
        L, Ld = leg_length_rate(q, v, k, params.joints, Ab, wb)
        out.lengths[row, k] = L
        out.length_rates[row, k] = Ld
    out.constraint_drift[row] = drift
    out.euler_norm_error[row] = norm_error
    kin = 0.0
    pot = 0.0
    for b in range(13):
        o = 6 * b
        w = (v[o + 3], v[o + 4], v[o + 5])
        kin += 0.5 * mass[b] * (v[o] ** 2 + v[o + 1] ** 2 + v[o + 2] ** 2)
        kin += 0.5 * dot3(w, matvec3(inertia[b], w))
        pot -= mass[b] * (gravity[0] * q[7 * b] + gravity[1] * q[7 * b + 1] + gravity[2] * q[7 * b + 2])
    out.kinetic[row] = kin
    out.potential[row] = pot


@jit
def observe(q, v, params, buffer):
    """:func:`observe_into` for one state, as an :class:`Observation` (``buffer``: a workspace)."""
    out = Observations(np.empty((1, 3)), np.empty((1, 4)), np.empty((1, 6)), np.empty((1, 6)),
                       np.empty(1), np.empty(1), np.empty(1), np.empty(1))
    observe_into(q, v, params, workspace(buffer), out, 0)
    return Observation(out.position[0], out.euler_parameters[0], out.lengths[0],
                       out.length_rates[0], out.constraint_drift[0], out.euler_norm_error[0],
                       out.kinetic[0], out.potential[0])
