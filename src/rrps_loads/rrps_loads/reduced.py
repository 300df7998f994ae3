"""Reduced 6-DOF dynamics of an RRPS robot in ring_b's twist t = (v, ω) relative to ring_a (ring_a's
frame): the independent cross-check of the paper's 13-body DAE (eqs. 19-20), by Kane's method::

    M(x) ṫ + Q0(x, t) = J(x)^T f        (J: the inverse Jacobian of eq. 1)

The moving bodies' kinematics: :mod:`rrps_loads.reduced_bodies`. Functions take N poses.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import cross
from rrps_kinematics.errors import ConvergenceError
from rrps_loads.reduced_bodies import (
    BodyMotion,
    PlatformPose,
    assembled_pose,
    body_accelerations,
    body_velocities,
    dot,
)
from rrps_loads.support import support_of

__all__ = [
    'ReducedState',
    'ReducedResult',
    'PlatformPose',
    'BodyMotion',
    'assembled_pose',
    'body_velocities',
    'body_accelerations',
    'mass_matrix',
    'generalized_forces',
    'kinetic_energy',
    'potential_energy',
    'platform_accelerations',
    'simulate_reduced',
]


def _unit_velocities(pose: PlatformPose) -> BodyMotion:
    """Body velocities for the six unit twists: leading axis k = twist component (6, N, ...)."""
    return body_velocities(pose, np.eye(6)[:, None, :])


def mass_matrix(pose: PlatformPose) -> np.ndarray:
    """M (N, 6, 6) of the reduced model: kinetic energy = 1/2 t^T M t."""
    g = pose.geometry
    V = _unit_velocities(pose)
    M = pose.free_mass * np.einsum('kni,jni->njk', V.ring, V.ring)
    M = M + np.einsum('kni,jni->njk', V.ring_angular, pose.ring_inertia_times(V.ring_angular))
    M = M + g.lower_link.mass * np.einsum('knli,jnli->njk', V.lower, V.lower)
    M = M + g.upper_link.mass * np.einsum('knli,jnli->njk', V.upper, V.upper)
    M = M + np.einsum('knli,jnli->njk', V.link_angular, pose.link_inertia_times(V.link_angular))
    return M


def generalized_forces(pose: PlatformPose, twist, twist_dot) -> np.ndarray:
    """J^T f needed for the motion (twist, twist_dot) (N, 6): inertia, gyroscopic, gravity and tool
    terms (Kane's generalized forces, eq. 19's right side); at rest :func:`rrps_loads.statics.static_load`."""
    g = pose.geometry
    twist = np.asarray(twist, dtype=float)
    V = _unit_velocities(pose)
    A = body_accelerations(pose, twist, twist_dot)
    w = body_velocities(pose, twist)
    grav = pose.loads.gravity
    ring_force = pose.free_mass * (A.ring - grav)
    ring_moment = (pose.ring_inertia_times(A.ring_angular)
                   + cross(w.ring_angular, pose.ring_inertia_times(w.ring_angular)))
    lower_force = g.lower_link.mass * (A.lower - grav[:, None, :])
    upper_force = g.upper_link.mass * (A.upper - grav[:, None, :])
    link_moment = (pose.link_inertia_times(A.link_angular)
                   + cross(w.link_angular, pose.link_inertia_times(w.link_angular)))
    Q = (np.einsum('kni,ni->nk', V.ring, ring_force)
         + np.einsum('kni,ni->nk', V.ring_angular, ring_moment)
         + np.einsum('knli,nli->nk', V.lower, lower_force)
         + np.einsum('knli,nli->nk', V.upper, upper_force)
         + np.einsum('knli,nli->nk', V.link_angular, link_moment))
    if pose.support.index == 0:
        tool = pose.loads
        at_tool = V.ring + cross(V.ring_angular, tool.tool_point - pose.free_com)
        Q = Q - (np.einsum('kni,ni->nk', at_tool, tool.tool_force)
                 + np.einsum('kni,ni->nk', V.ring_angular, tool.tool_torque))
    return Q


def kinetic_energy(pose: PlatformPose, twist) -> np.ndarray:
    """T (N,) [J] of the free ring and the twelve links for ring_b twists (N, 6)."""
    g = pose.geometry
    V = body_velocities(pose, twist)
    return 0.5 * (pose.free_mass * dot(V.ring, V.ring)
                  + dot(V.ring_angular, pose.ring_inertia_times(V.ring_angular))
                  + g.lower_link.mass * np.sum(dot(V.lower, V.lower), axis=-1)
                  + g.upper_link.mass * np.sum(dot(V.upper, V.upper), axis=-1)
                  + np.sum(dot(V.link_angular, pose.link_inertia_times(V.link_angular)), axis=-1))


def potential_energy(pose: PlatformPose) -> np.ndarray:
    """Gravity potential V (N,) [J] = -sum m g . com of the moving bodies, zero with every com
    at the supporting ring's origin."""
    g = pose.geometry
    grav = pose.loads.gravity
    origin = (np.zeros_like(pose.position) if pose.support.index == 0 else pose.position)[:, None, :]
    return -(pose.free_mass * dot(pose.free_com - origin[:, 0], grav)
             + g.lower_link.mass * np.sum(dot(pose.lower_com - origin, grav[:, None, :]), axis=-1)
             + g.upper_link.mass * np.sum(dot(pose.upper_com - origin, grav[:, None, :]), axis=-1))


def platform_accelerations(pose: PlatformPose, twist, forces) -> np.ndarray:
    """Forward dynamics: t_dot (N, 6) = M^-1 (J^T f - Q0) for twists (N, 6) and forces (N, 6)."""
    twist = np.asarray(twist, dtype=float)
    Q0 = generalized_forces(pose, twist, np.zeros_like(twist))
    rhs = np.einsum('nji,nj->ni', pose.inverse_jacobian, np.asarray(forces, dtype=float)) - Q0
    return np.linalg.solve(mass_matrix(pose), rhs[..., None])[..., 0]


@dataclass(frozen=True)
class ReducedState:
    """State handed to a force callable: ring_b pose and twist in ring_a's frame."""

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray


@dataclass(frozen=True)
class ReducedResult:
    """One reduced-model run sampled every output step (K samples), SI units; the energy balance
    ``kinetic_energy + potential_energy - actuator_work`` stays constant without a tool wrench."""

    t: np.ndarray
    position: np.ndarray
    quaternion_xyzw: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    lengths: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    actuator_work: np.ndarray
    evaluations: int

    @property
    def energy_balance(self) -> np.ndarray:
        """T + V - W (K,) [J]: constant for an exact solution."""
        return self.kinetic_energy + self.potential_energy - self.actuator_work


def _check_forces(value, what: str) -> np.ndarray:
    f = np.asarray(value, dtype=float)
    if f.shape != (6,):
        raise ValueError(f'{what} must have shape (6,), got {f.shape}')
    if not np.all(np.isfinite(f)):
        raise ValueError(f'{what} contains NaN or infinite values')
    return f


def simulate_reduced(geometry: RobotGeometry, position, quaternion_xyzw,
                     forces: np.ndarray | Callable[[float, ReducedState], np.ndarray],
                     duration: float, dt: float, *,
                     velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0),
                     rtol: float = 1e-11, atol: float = 1e-13, support='ring_a',
                     world_q_support=None, gravity=None) -> ReducedResult:
    """Integrate the reduced model from a pose (at rest unless velocities are given) on ``support``
    (:func:`rrps_loads.support.support_of`), sampled every ``dt`` to ``duration`` (DOP853).

    ``forces``: constant (6,) [N] (+ pushes the rings apart; the paper's constant-force run) or
    ``forces(t, ReducedState)``, best smooth in t (kinks cost many steps).
    """
    for key, value in (('duration', duration), ('dt', dt)):
        if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
            raise ValueError(f'{key} must be a positive finite number, got {value!r}')
    steps = int(round(duration / dt))
    if steps < 1 or abs(steps * dt - duration) > 1e-9 * max(duration, 1.0):
        raise ValueError(f'duration ({duration}) must be a positive multiple of dt ({dt})')
    if callable(forces):
        force_fn = forces
    else:
        constant = _check_forces(forces, 'forces')

        def force_fn(t, state):
            return constant
    v0 = _check_forces(np.concatenate([np.asarray(velocity, float).ravel(),
                                       np.asarray(angular_velocity, float).ravel()]),
                       'velocity and angular_velocity (3 + 3)')
    world = support_of(support, world_q_support, gravity)
    pose0 = PlatformPose(geometry, position, quaternion_xyzw, world)
    q0 = np.asarray(quaternion_xyzw, dtype=float)
    y0 = np.concatenate([pose0.position[0], q0 / np.linalg.norm(q0), v0, [0.0]])

    def state_of(t, y):
        q = y[3:7] / np.linalg.norm(y[3:7])
        return ReducedState(y[:3], q, y[7:10], y[10:13])

    def rhs(t, y):
        s = state_of(t, y)
        f = _check_forces(force_fn(t, s), f'forces({t:.6g}, state)')
        pose = PlatformPose(geometry, s.position, s.quaternion_xyzw, world)
        twist = y[7:13][None]
        acc = platform_accelerations(pose, twist, f[None])[0]
        w = y[10:13]
        qv, qw = s.quaternion_xyzw[:3], s.quaternion_xyzw[3]
        q_dot = 0.5 * np.concatenate([qw * w + cross(w, qv), [-np.dot(w, qv)]])
        work_rate = np.dot(f, pose.inverse_jacobian[0] @ y[7:13])
        return np.concatenate([y[7:10], q_dot, acc, [work_rate]])

    t_eval = dt * np.arange(steps + 1)
    sol = solve_ivp(rhs, (0.0, t_eval[-1]), y0, method='DOP853', t_eval=t_eval,
                    rtol=rtol, atol=atol)
    if not sol.success:
        raise ConvergenceError(f'reduced-model integration failed: {sol.message}')
    Y = sol.y.T
    quat = Y[:, 3:7] / np.linalg.norm(Y[:, 3:7], axis=1, keepdims=True)
    pose = PlatformPose(geometry, Y[:, :3], quat, world)
    return ReducedResult(
        t=sol.t, position=Y[:, :3], quaternion_xyzw=quat, velocity=Y[:, 7:10],
        angular_velocity=Y[:, 10:13], lengths=pose.lengths,
        kinetic_energy=kinetic_energy(pose, Y[:, 7:13]), potential_energy=potential_energy(pose),
        actuator_work=Y[:, 13], evaluations=int(sol.nfev))
