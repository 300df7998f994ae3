"""The moving bodies of the reduced 6-DOF model (:mod:`rrps_loads.reduced`): ring_b's pose, and
every body's velocity and acceleration for ring_b's twist, exact (no finite differences).

Per leg (eq. 1, d_i = B_i - a_i = L_i u_i): ring_b, the lower and upper links, both turning with
the universal joint's cross, ω_link = α x1_i + β n_i, n_i = u_i × x1_i (no spin about the leg).
Motions are relative to the supporting ring, in ring_a's frame. With ring_b supporting, ring_a
moves so that ring_b stays: a body at x (d = x - r) moves with V = ẋ - v - ω × d, W = w_rel - ω,
a = ẍ - v̇ - ω̇ × d - 2 ω × (ẋ - v) + ω × (ω × d), α = ẇ_rel - ω̇ - ω × w_rel. N poses at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import cross
from rrps_kinematics.errors import SingularPoseError
from rrps_kinematics.inverse import inverse_kinematics, universal_joint_frames
from rrps_kinematics.jacobian import inverse_jacobian
from rrps_loads.support import Support, world_loads

__all__ = ['PlatformPose', 'BodyMotion', 'assembled_pose', 'body_velocities', 'body_accelerations', 'dot']

# Smallest |u x x1|^2 accepted: below it the universal joint is locked (its two axes aligned).
_UNIVERSAL_LOCK = 1e-10


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product over the last axis."""
    return np.sum(a * b, axis=-1)


def assembled_pose(geometry: RobotGeometry, position, quaternion_xyzw):
    """IK of N poses checked to be a valid assembly: (ik, x1 (6, 3), n = u × x1 (N, 6, 3)).
    Raises ValueError for invalid input, SingularPoseError for a zero-length leg or a locked
    universal joint."""
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
    if np.any(dot(n, n) < _UNIVERSAL_LOCK):
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
        self.n_sq = dot(self.n, self.n)
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
                + (self.link_axial - self.link_transverse) * dot(self.u, w)[..., None] * self.u)

    def ring_inertia_times(self, w: np.ndarray) -> np.ndarray:
        """The free ring's inertia (ring_a's frame) times its angular velocities w (..., N, 3)."""
        return np.einsum('nij,...nj->...ni', self.free_inertia, w)


@dataclass(frozen=True)
class BodyMotion:
    """Velocities (or accelerations) of the moving bodies relative to the supporting ring, in ring_a's
    frame: the free ring's, each leg's link coms and shared angular motion, and ``leg_rates``."""

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
    l_dot = dot(pose.u, b_dot)
    u_dot = (b_dot - l_dot[..., None] * pose.u) / pose.lengths[..., None]
    alpha = -dot(pose.n, u_dot) / pose.n_sq
    beta = dot(pose.m, u_dot) / pose.n_sq
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
    l_ddot = dot(r.u_dot, r.b_dot) + dot(u, b_ddot)
    u_ddot = (b_ddot - l_ddot[..., None] * u - 2.0 * r.l_dot[..., None] * r.u_dot) / L
    n_dot = cross(r.u_dot, pose.x1)
    s_dot = 2.0 * dot(n, n_dot)
    m_dot = cross(n_dot, u) + cross(n, r.u_dot)
    alpha_dot = (-(dot(n_dot, r.u_dot) + dot(n, u_ddot)) - r.alpha * s_dot) / pose.n_sq
    beta_dot = (dot(m_dot, r.u_dot) + dot(pose.m, u_ddot) - r.beta * s_dot) / pose.n_sq
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
