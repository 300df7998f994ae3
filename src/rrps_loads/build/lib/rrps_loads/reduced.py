"""Reduced 6-DOF dynamics of an RRPS robot in ring_b's pose (the independent cross-check).

The paper integrates 13 bodies x 7 coordinates with 91 constraints (eqs. 19-20). Here the same
mechanism is written in its 6 independent velocities, the twist t = (v, omega) of ring_b
relative to ring_a (origin velocity and angular velocity, both in ring_a's frame: the twist of
:mod:`rrps_kinematics.jacobian`), by Kane's method / virtual power::

    M(x) t_dot + Q0(x, t) = J(x)^T f

    M   = sum_bodies  m V_k^T V_k + W_k^T I W_k          (V_k, W_k: com and angular velocity
    Q0  = sum_bodies  V_k^T m (a_bias - g) + W_k^T (I alpha_bias + w x I w)     per unit twist)

with J the inverse Jacobian of eq. 1 (so J^T f is the power of the actuator forces f_i l_dot_i).

Bodies and their exact kinematics *relative to ring_a*, for leg i with universal-joint centre
a_i (ring_a frame), spherical-joint centre B_i = r + A_c s'_i and leg vector
d_i = B_i - a_i = L_i u_i (eq. 1):

* ring_b: com r + A_c c_b, angular velocity omega, inertia A_c J'_b A_c^T.
* lower link: com a_i + c_lower u_i; upper link: com B_i - c_upper u_i (prismatic pair).
* both links turn together with the universal joint's cross: omega_link = alpha x1_i + beta n_i,
  x1_i the revolute axis fixed in ring_a, n_i = u_i x x1_i the cross's second axis; u_dot =
  omega_link x u fixes alpha = -(n.u_dot)/|n|^2 and beta = ((n x u).u_dot)/|n|^2 (no free spin
  about the leg). Link inertias diag(I_t, I_t, I_axial) with z along the leg are I_t 1 + (I_axial
  - I_t) u u^T in ring_a's frame, independent of the spin angle.

The supporting ring is the inertial frame. With ring_a supporting these are the motions. With
ring_b supporting, ring_a moves so that ring_b stays: ring_a's frame turns with -omega, and a
body at x (ring_a's frame, d = x - r) moves with V = x_dot - v - omega x d, W = w_rel - omega and
accelerates with a = x_ddot - v_dot - omega_dot x d - 2 omega x (x_dot - v) + omega x (omega x d),
alpha = w_rel_dot - omega_dot - omega x w_rel (all in ring_a's frame; ring_b's motion vanishes,
ring_a's is that of a point fixed in it). The leg spin stays tied to ring_a, whose universal
joints it has. Accelerations follow by differentiating once more (no finite differences). All
functions take a batch of N poses; the twist arguments broadcast against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Callable, NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import cross
from rrps_kinematics.errors import ConvergenceError, SingularPoseError
from rrps_kinematics.inverse import inverse_kinematics, universal_joint_frames
from rrps_kinematics.jacobian import inverse_jacobian
from rrps_loads.support import Support, support_of, world_loads

__all__ = [
    'ReducedState',
    'ReducedResult',
    'PlatformPose',
    'BodyMotion',
    'body_velocities',
    'body_accelerations',
    'mass_matrix',
    'generalized_forces',
    'kinetic_energy',
    'potential_energy',
    'platform_accelerations',
    'simulate_reduced',
]

# Smallest |u x x1|^2 accepted: below it the universal joint is locked (its two axes aligned).
_UNIVERSAL_LOCK = 1e-10


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def assembled_pose(geometry: RobotGeometry, position, quaternion_xyzw):
    """IK of N poses (position (N, 3) or (3,)) checked to be a valid assembly of the model.

    Returns (ik, x1, n): the IK result, each universal joint's fixed axis x1 (6, 3) and
    n = u × x1 (N, 6, 3). Raises ValueError for a non-RobotGeometry or invalid poses (shapes, NaN,
    zero quaternion); SingularPoseError (a ValueError too) for a zero-length leg or a locked
    universal joint (leg along its fixed axis).
    """
    if not isinstance(geometry, RobotGeometry):
        raise ValueError(f'geometry must be a RobotGeometry, got {type(geometry).__name__}')
    p = np.asarray(position, dtype=float)
    q = np.asarray(quaternion_xyzw, dtype=float)
    if p.ndim == 1:
        p, q = p[None], q[None]
    ik = inverse_kinematics(geometry, p, q)  # validates shapes, NaN, zero quaternions
    if np.any(ik.lengths < 1e-9):
        raise SingularPoseError('singular pose: a leg has zero length, the pose is not a valid '
                                'assembly')
    x1 = universal_joint_frames(geometry)[:, :, 0]
    n = cross(ik.unit_vectors, x1)
    if np.any(_dot(n, n) < _UNIVERSAL_LOCK):
        raise SingularPoseError('singular pose: a universal joint is locked (leg along its fixed '
                                'axis), the link rotation is undefined')
    return ik, x1, n


class PlatformPose:
    """Pose-dependent quantities of N poses of ring_b (position (N, 3), quaternion (N, 4)), and
    the world's loads there for a ``support`` (:class:`~rrps_loads.support.Support`, default:
    ring_a upright under the standard gravity)."""

    def __init__(self, geometry: RobotGeometry, position, quaternion_xyzw, support: Support | None = None):
        self.geometry = geometry
        self.support = Support.of() if support is None else support
        self.ik, self.x1, self.n = assembled_pose(geometry, position, quaternion_xyzw)
        p = self.ik.position
        self.rotation = self.ik.rotation                                   # (N, 3, 3)
        self.position = p                                                  # (N, 3)
        self.lengths = self.ik.lengths                                     # (N, 6)
        self.u = self.ik.unit_vectors                                      # (N, 6, 3)
        self.anchors_b = self.ik.leg_vectors + geometry.ring_a_anchors - p[:, None, :]  # A_c s'_i
        self.n_sq = _dot(self.n, self.n)
        self.m = cross(self.n, self.u)
        self.com_b = np.einsum('nij,j->ni', self.rotation, geometry.ring_b_body.com)
        lo, up = geometry.lower_link, geometry.upper_link
        self.lower_com = geometry.ring_a_anchors + lo.com_from_joint * self.u     # (N, 6, 3)
        self.upper_com = self.ik.ring_b_anchors_in_a - up.com_from_joint * self.u
        self.loads = world_loads(geometry, self.support, p, self.rotation)
        if self.support.index == 0:
            self.free_mass = geometry.ring_b_body.mass
            self.free_com = p + self.com_b                                   # (N, 3)
            self.free_inertia = self.rotation @ geometry.ring_b_body.inertia @ np.swapaxes(
                self.rotation, -1, -2)
        else:
            self.free_mass = geometry.ring_a_body.mass
            self.free_com = np.broadcast_to(geometry.ring_a_body.com, p.shape)
            self.free_inertia = np.broadcast_to(geometry.ring_a_body.inertia, self.rotation.shape)
        # Both links share one rotation: their angular inertias add up.
        self.link_transverse = lo.inertia_transverse + up.inertia_transverse
        self.link_axial = lo.inertia_axial + up.inertia_axial

    @cached_property
    def inverse_jacobian(self) -> np.ndarray:
        """J (N, 6, 6) of rrps_kinematics: leg rates = J @ twist."""
        return inverse_jacobian(self.ik)

    def link_inertia_times(self, w: np.ndarray) -> np.ndarray:
        """(I_lower + I_upper) w for link angular velocities w (..., N, 6, 3), ring_a frame."""
        return (self.link_transverse * w
                + (self.link_axial - self.link_transverse) * _dot(self.u, w)[..., None] * self.u)

    def ring_inertia_times(self, w: np.ndarray) -> np.ndarray:
        """The free ring's inertia (ring_a's frame) times its angular velocities w (..., N, 3)."""
        return np.einsum('nij,...nj->...ni', self.free_inertia, w)


@dataclass(frozen=True)
class BodyMotion:
    """Com velocities (or accelerations) and angular velocities (or accelerations) of the moving
    bodies relative to the supporting ring, in ring_a's frame.

    ``ring`` (..., N, 3), ``ring_angular`` (..., N, 3) of the free ring (ring_b when ring_a
    supports, ring_a when ring_b does), ``lower`` / ``upper`` (..., N, 6, 3) link coms,
    ``link_angular`` (..., N, 6, 3) shared by each leg's two links, and ``leg_rates`` (..., N, 6)
    = l_dot (or l_ddot).
    """

    ring: np.ndarray
    ring_angular: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    link_angular: np.ndarray
    leg_rates: np.ndarray


class _LegRates(NamedTuple):
    b_dot: np.ndarray
    l_dot: np.ndarray
    u_dot: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray


def _leg_rates(pose: PlatformPose, twist: np.ndarray) -> _LegRates:
    v, w = twist[..., None, :3], twist[..., None, 3:]
    b_dot = v + cross(w, pose.anchors_b)                      # velocity of B_i
    l_dot = _dot(pose.u, b_dot)
    u_dot = (b_dot - l_dot[..., None] * pose.u) / pose.lengths[..., None]
    alpha = -_dot(pose.n, u_dot) / pose.n_sq
    beta = _dot(pose.m, u_dot) / pose.n_sq
    return _LegRates(b_dot, l_dot, u_dot, alpha, beta)


def _relative_velocities(pose: PlatformPose, twist: np.ndarray) -> BodyMotion:
    """Body velocities relative to ring_a (``ring``: ring_b's)."""
    g = pose.geometry
    r = _leg_rates(pose, twist)
    w = twist[..., 3:]
    return BodyMotion(
        ring=twist[..., :3] + cross(w, pose.com_b),
        ring_angular=w,
        lower=g.lower_link.com_from_joint * r.u_dot,
        upper=r.b_dot - g.upper_link.com_from_joint * r.u_dot,
        link_angular=r.alpha[..., None] * pose.x1 + r.beta[..., None] * pose.n,
        leg_rates=r.l_dot,
    )


def body_velocities(pose: PlatformPose, twist) -> BodyMotion:
    """Velocities of every moving body for ring_b twists (..., N, 6) relative to ring_a
    (v, omega in ring_a's frame), relative to the supporting ring (module docstring)."""
    twist = np.asarray(twist, dtype=float)
    rel = _relative_velocities(pose, twist)
    if pose.support.index == 0:
        return rel
    v, w = twist[..., None, :3], twist[..., None, 3:]
    p = pose.position[..., None, :]

    def moving(x_dot, x):
        return x_dot - v - cross(w, x - p)

    return BodyMotion(
        ring=-twist[..., :3] - cross(twist[..., 3:], pose.free_com - pose.position),
        ring_angular=-twist[..., 3:],
        lower=moving(rel.lower, pose.lower_com), upper=moving(rel.upper, pose.upper_com),
        link_angular=rel.link_angular - w, leg_rates=rel.leg_rates)


def _relative_accelerations(pose: PlatformPose, twist: np.ndarray, twist_dot: np.ndarray) -> BodyMotion:
    """Body accelerations relative to ring_a (``ring``: ring_b's)."""
    g = pose.geometry
    r = _leg_rates(pose, twist)
    w, w_dot = twist[..., None, 3:], twist_dot[..., None, 3:]
    u, n, L = pose.u, pose.n, pose.lengths[..., None]
    b_ddot = (twist_dot[..., None, :3] + cross(w_dot, pose.anchors_b)
              + cross(w, cross(w, pose.anchors_b)))
    l_ddot = _dot(r.u_dot, r.b_dot) + _dot(u, b_ddot)
    u_ddot = (b_ddot - l_ddot[..., None] * u - 2.0 * r.l_dot[..., None] * r.u_dot) / L
    n_dot = cross(r.u_dot, pose.x1)
    s_dot = 2.0 * _dot(n, n_dot)
    m_dot = cross(n_dot, u) + cross(n, r.u_dot)
    alpha_dot = (-(_dot(n_dot, r.u_dot) + _dot(n, u_ddot)) - r.alpha * s_dot) / pose.n_sq
    beta_dot = (_dot(m_dot, r.u_dot) + _dot(pose.m, u_ddot) - r.beta * s_dot) / pose.n_sq
    wr, wr_dot = twist[..., 3:], twist_dot[..., 3:]
    return BodyMotion(
        ring=(twist_dot[..., :3] + cross(wr_dot, pose.com_b)
              + cross(wr, cross(wr, pose.com_b))),
        ring_angular=wr_dot,
        lower=g.lower_link.com_from_joint * u_ddot,
        upper=b_ddot - g.upper_link.com_from_joint * u_ddot,
        link_angular=(alpha_dot[..., None] * pose.x1 + beta_dot[..., None] * n
                      + r.beta[..., None] * n_dot),
        leg_rates=l_ddot,
    )


def body_accelerations(pose: PlatformPose, twist, twist_dot) -> BodyMotion:
    """Accelerations of every moving body, relative to the supporting ring, for ring_b twists
    and their rates (..., N, 6) relative to ring_a."""
    twist = np.asarray(twist, dtype=float)
    twist_dot = np.asarray(twist_dot, dtype=float)
    rel = _relative_accelerations(pose, twist, twist_dot)
    if pose.support.index == 0:
        return rel
    vel = _relative_velocities(pose, twist)
    v, w = twist[..., None, :3], twist[..., None, 3:]
    v_dot, w_dot = twist_dot[..., None, :3], twist_dot[..., None, 3:]
    p = pose.position[..., None, :]

    def moving(x_ddot, x_dot, x):
        d = x - p
        return x_ddot - v_dot - cross(w_dot, d) - 2.0 * cross(w, x_dot - v) + cross(w, cross(w, d))

    ring = moving(np.zeros(3), np.zeros(3), pose.free_com[..., None, :])[..., 0, :]
    return BodyMotion(
        ring=ring, ring_angular=-twist_dot[..., 3:],
        lower=moving(rel.lower, vel.lower, pose.lower_com),
        upper=moving(rel.upper, vel.upper, pose.upper_com),
        link_angular=rel.link_angular - w_dot - cross(w, vel.link_angular),
        leg_rates=rel.leg_rates)


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
    """J^T f needed for the motion (twist, twist_dot) (N, 6): inertia, gyroscopic, gravity and
    tool-wrench terms.

    Component k is the power of (m a - m g) and (I alpha + omega x I omega) of every moving body
    for the unit twist e_k, minus that of the tool wrench when ring_b moves (Kane's generalized
    inertia + active forces, with the sign of eq. 19's right side moved over). With twist =
    twist_dot = 0 it is the static load of eq. 19 (:func:`rrps_loads.statics.static_load`).
    """
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
    return 0.5 * (pose.free_mass * _dot(V.ring, V.ring)
                  + _dot(V.ring_angular, pose.ring_inertia_times(V.ring_angular))
                  + g.lower_link.mass * np.sum(_dot(V.lower, V.lower), axis=-1)
                  + g.upper_link.mass * np.sum(_dot(V.upper, V.upper), axis=-1)
                  + np.sum(_dot(V.link_angular, pose.link_inertia_times(V.link_angular)), axis=-1))


def potential_energy(pose: PlatformPose) -> np.ndarray:
    """Gravity potential V (N,) [J] = -sum m g . com of the moving bodies, zero with every com
    at the supporting ring's origin."""
    g = pose.geometry
    grav = pose.loads.gravity
    origin = (np.zeros_like(pose.position) if pose.support.index == 0 else pose.position)[:, None, :]
    return -(pose.free_mass * _dot(pose.free_com - origin[:, 0], grav)
             + g.lower_link.mass * np.sum(_dot(pose.lower_com - origin, grav[:, None, :]), axis=-1)
             + g.upper_link.mass * np.sum(_dot(pose.upper_com - origin, grav[:, None, :]), axis=-1))


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
    """One reduced-model run sampled every output step (K samples).

    ``t`` (K,), ``position`` (K, 3), ``quaternion_xyzw`` (K, 4), ``velocity`` /
    ``angular_velocity`` (K, 3), ``lengths`` (K, 6), energies [J] (K,): ``kinetic_energy``,
    ``potential_energy`` and ``actuator_work`` (integral of f . l_dot), whose balance
    T + V - W stays constant without a tool wrench; ``evaluations``: right-hand-side calls of the integrator.
    """

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
    """Integrate the reduced model from a pose (at rest unless velocities are given), on the
    ``support`` ring turned by ``world_q_support`` in a world of ``gravity``
    (:func:`rrps_loads.support.support_of`; default ring_a upright, 9.81 m/s² down).

    ``forces``: constant actuator forces (6,) [N] (+ = pushing the rings apart) — the paper's
    constant-force run — or ``forces(t, ReducedState) -> (6,)``, best smooth in t (the step
    size adapts: kinks, e.g. of linearly interpolated samples, cost many steps). Samples every
    ``dt`` from 0 to ``duration`` (a multiple of ``dt``). Integration: scipy's DOP853 (8th
    order, adaptive) at ``rtol``/``atol`` on the state (r, q, v, omega, W); the quaternion is
    normalised inside the right-hand side, q_dot = 1/2 (omega, 0) ⊗ q.
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
