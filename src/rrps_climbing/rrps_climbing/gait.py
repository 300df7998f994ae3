"""The inchworm climbing gait (§3; the 800 mm / 11-step path of §2.2).

One step up (ring_b leads; down, ring_a leads)::

    release_b -> move_b -> grip_b -> release_a -> move_a -> grip_a

Every sampled pose is checked against ``rrps_kinematics.limits``, the legs' clearance to the
member and the gripper interlock, and, with a :class:`~rrps_climbing.load_check.LoadCheck`, the
loads; a plan that breaks one raises ``PlanError`` (the limit, the legs, where). The extra ring
DOF (§3.1, Fig. 9) turns the open ring's gripper so the legs are not twisted (Fig. 8c). No ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_climbing.load_check import LoadCheck, time_phases
from rrps_climbing.plan import ClimbPlan, Phase, PlanError, PlanLimit, check_interlock
from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_description.rotations import matrix_to_quat_xyzw, rotation_angle_between
from rrps_description.structures import Structure, interpolate_frames
from rrps_interfaces.climb import PhaseAction
from rrps_kinematics import inverse_kinematics, margins
from rrps_kinematics.odometry import RingOdometry, invert, rot_z, transform

__all__ = ['GaitPlanner', 'GaitState', 'plan_climb']

@dataclass
class GaitState:
    """Where the rings grip while a plan is built: route positions [m], extra-DOF angles [rad]."""

    s_a: float
    s_b: float
    theta_a: float
    theta_b: float


class GaitPlanner:
    """Plans inchworm climbs of one robot on one structure.

    ``spacing`` [m]: the largest distance between checked poses; ``step_fraction``: the default
    step as a fraction of the straight-member ``reach``; ``loads``: None times the motions within
    the legs' limits alone and checks no load.
    """

    def __init__(self, geometry: RobotGeometry, structure: Structure, *, use_extra_dof: bool = True,
                 spacing: float = 0.01, step_fraction: float = 0.7, loads: LoadCheck | None = LoadCheck()):
        if not (spacing > 0.0 and 0.0 < step_fraction <= 1.0):
            raise ValueError('spacing must be > 0 and 0 < step_fraction <= 1')
        self.geometry = geometry
        self.structure = structure
        self.loads = loads
        self.spacing = float(spacing)
        self._last_mounts: tuple | None = None  # ((theta_a, theta_b), mounts): see mounts()
        self.surface = structure.kind == 'surface'
        self.standoff = float(geometry.home_position[2])
        self.dof = (use_extra_dof and structure.kind == 'member'
                    and {'ring_a', 'ring_b'} <= set(geometry.extra_dof))
        self.sep_home = 0.0 if self.surface else self.standoff
        self.reach = self._reach()
        self.default_step = step_fraction * (self.reach[1] - self.reach[0])

    # --- geometry of a configuration ----------------------------------------------------

    def _straight(self, sep: np.ndarray) -> np.ndarray:
        sep = np.atleast_1d(np.asarray(sep, dtype=float))
        p = (np.c_[sep, np.zeros_like(sep), np.full_like(sep, self.standoff)] if self.surface
             else np.c_[np.zeros_like(sep), np.zeros_like(sep), sep])
        return p

    def _reach(self) -> tuple[float, float]:
        """Separations (route distance ring_b - ring_a) reachable on a straight member or flat
        surface within every limit, around the home pose, 1 mm resolution."""
        span = self.geometry.max_length
        sep = np.arange(self.sep_home - span, self.sep_home + span, 0.001)
        q = np.tile([0.0, 0.0, 0.0, 1.0], (len(sep), 1))
        ok = np.asarray(margins(self.geometry, inverse_kinematics(self.geometry, self._straight(sep), q)).ok)
        i = int(np.argmin(np.abs(sep - self.sep_home)))
        if not ok[i]:
            raise ValueError(f'{self.geometry.name}: the home pose breaks a limit')
        lo = i
        while lo > 0 and ok[lo - 1]:
            lo -= 1
        hi = i
        while hi < len(sep) - 1 and ok[hi + 1]:
            hi += 1
        return float(sep[lo]), float(sep[hi])

    def _mount_matrices(self, theta_a, theta_b) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`mounts` as 4x4 matrices, for angles that may be arrays (n,) -> (n, 4, 4)."""
        b = rot_z(theta_b)
        if self.surface:
            b = transform((0.0, 0.0, -self.standoff)) @ b
        return rot_z(theta_a), b

    def _ring_matrices(self, s_a: float, s_b: float, theta_a: float, theta_b: float):
        """:meth:`world_rings` as 4x4 matrices."""
        ma, mb = self._mount_matrices(theta_a, theta_b)
        return (transform(*self.structure.grip_frame(s_a)) @ invert(ma),
                transform(*self.structure.grip_frame(s_b)) @ invert(mb))

    def mounts(self, theta_a: float, theta_b: float) -> tuple[Pose, Pose]:
        """(a_T_grip_a, b_T_grip_b): the extra DOF about each ring's z, and on a surface ring_b's
        stand-off (its feet reach down to the wall)."""
        key = (float(theta_a), float(theta_b))
        if self._last_mounts is None or self._last_mounts[0] != key:  # odometry asks at 50 Hz
            ma, mb = self._mount_matrices(theta_a, theta_b)
            self._last_mounts = (key, (Pose.from_matrix(ma), Pose.from_matrix(mb)))
        return self._last_mounts[1]

    def world_rings(self, s_a: float, s_b: float, theta_a: float, theta_b: float) -> tuple[Pose, Pose]:
        """(world_T_a, world_T_b) with both grippers at their grip frames."""
        wa, wb = self._ring_matrices(s_a, s_b, theta_a, theta_b)
        return Pose.from_matrix(wa), Pose.from_matrix(wb)

    # --- checking ----------------------------------------------------------------------------

    def _check(self, world_T_a: np.ndarray, world_T_b: np.ndarray, s_range, where: str,
               step: int, phase: str) -> tuple[np.ndarray, np.ndarray, dict]:
        """Check the sampled poses (n, 4, 4); return (a_T_b path, end lengths, min margins)."""
        path = invert(world_T_a) @ world_T_b
        g = self.geometry
        m = margins(g, inverse_kinematics(g, path[:, :3, 3], matrix_to_quat_xyzw(path[:, :3, :3])))
        clearance = self._clearance(world_T_a, world_T_b, s_range)
        bad = ~np.asarray(m.ok)
        if clearance is not None:
            bad |= np.any(~(clearance >= 0.0), axis=1)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            q_k = matrix_to_quat_xyzw(path[k, :3, :3])
            broken = margins(g, inverse_kinematics(g, path[k, :3, 3], q_k)).broken()
            lines = [str(v) for v in broken]
            too_close = [] if clearance is None else np.flatnonzero(~(clearance[k] >= 0.0))
            for i in too_close:
                lines.append(f'structure clearance: leg_{i + 1} is {clearance[k][i] + g.leg_radius:.4f} m '
                             f'from the {self.structure.name} surface < leg radius {g.leg_radius:.4f} m')
            if broken:
                limit, legs = PlanLimit(broken[0].kind.value), [f'leg_{i}' for i in broken[0].legs]
            else:
                limit, legs = PlanLimit.CLEARANCE, [f'leg_{too_close[0] + 1}']
            at_k = {'stroke': float(np.min(m.stroke[k])), 'universal': float(np.min(m.universal[k])),
                    'spherical': float(np.min(m.spherical[k])),
                    'interference': float(np.min(m.interference[k])),
                    'conditioning': float(m.conditioning[k]),
                    'clearance': math.nan if clearance is None else float(np.min(clearance[k]))}
            raise PlanError(f'step {step}, phase {phase} ({where}, pose {k + 1}/{len(path)}): '
                            + '; '.join(lines), limit=limit, legs=legs,
                            step=step, phase=phase, margins=at_k)
        mins = {'stroke': float(np.min(m.stroke)), 'universal': float(np.min(m.universal)),
                'spherical': float(np.min(m.spherical)), 'interference': float(np.min(m.interference)),
                'conditioning': float(np.min(m.conditioning)),
                'clearance': math.nan if clearance is None else float(np.min(clearance))}
        return path, np.asarray(m.lengths)[-1].copy(), mins

    def _clearance(self, world_T_a, world_T_b, s_range):
        """Distance of every leg segment to a tube's surface minus the leg radius, (n, 6)."""
        lo, hi = min(s_range) - 0.05, max(s_range) + 0.05
        lo, hi = max(lo, 0.0), min(hi, self.structure.length)
        pts = self.structure.clearance_points(lo, hi)
        if pts is None:
            return None
        P, r = pts
        g = self.geometry
        A = np.einsum('nij,kj->nki', world_T_a[:, :3, :3], g.ring_a_anchors) + world_T_a[:, None, :3, 3]
        B = np.einsum('nij,kj->nki', world_T_b[:, :3, :3], g.ring_b_anchors) + world_T_b[:, None, :3, 3]
        d = B - A                                                        # (n, 6, 3)
        w = P[None, None, :, :] - A[:, :, None, :]                       # (n, 6, M, 3)
        t = np.clip(np.einsum('nkmj,nkj->nkm', w, d) / np.einsum('nkj,nkj->nk', d, d)[..., None], 0.0, 1.0)
        gap = np.linalg.norm(w - t[..., None] * d[:, :, None, :], axis=-1)  # (n, 6, M)
        return np.min(gap - r[None, None, :], axis=-1) - g.leg_radius

    # --- phases ---------------------------------------------------------------------------------

    def _phase(self, state: GaitState, step: int, action: PhaseAction, ring: str, grip_a: bool,
               grip_b: bool, world_T_a=None, world_T_b=None, s_range=None,
               ring_angles=None) -> Phase:
        if world_T_a is None:
            wa, wb = self._ring_matrices(state.s_a, state.s_b, state.theta_a, state.theta_b)
            world_T_a, world_T_b = wa[None], wb[None]
        name = action.value + (f'_{ring[-1]}' if ring else '')
        path, lengths, mins = self._check(world_T_a, world_T_b, s_range or (state.s_a, state.s_b),
                                          f's_a={state.s_a:.3f} m, s_b={state.s_b:.3f} m', step, name)
        return Phase(step=step, action=action, ring=ring, gripper_a=grip_a, gripper_b=grip_b, s_a=state.s_a,
                     s_b=state.s_b, theta_a=state.theta_a, theta_b=state.theta_b, path=path,
                     lengths=lengths, min_margins=mins, ring_angles=ring_angles)

    def _twist(self, world_T_ring: np.ndarray, world_T_partner: np.ndarray) -> float:
        """Angle [rad] of the ring about its z axis relative to its partner ring."""
        M = world_T_partner[:3, :3].T @ world_T_ring[:3, :3]
        return math.atan2(M[1, 0] - M[0, 1], M[0, 0] + M[1, 1])

    def _dof_target(self, ring: str, theta0: float, twist: float, step: int) -> float:
        """The open ring's extra-DOF angle that cancels ``twist``, wrapped into the joint range."""
        dof = self.geometry.extra_dof[f'ring_{ring}']
        theta = theta0 + twist
        for shift in (0.0, -2.0 * math.pi, 2.0 * math.pi):
            if dof.min_angle <= theta + shift <= dof.max_angle:
                return theta + shift
        raise PlanError(f'step {step}, phase move_{ring}: extra_dof: ring_{ring} angle {theta:.3f} rad '
                        f'outside [{dof.min_angle:.3f}, {dof.max_angle:.3f}] rad', limit=PlanLimit.EXTRA_DOF,
                        step=step, phase=f'move_{ring}')

    def _move(self, state: GaitState, step: int, ring: str, target: float) -> list[Phase]:
        """release, move along the structure, grip: one ring to route position ``target``.

        With the extra ring DOF the open ring's joint turns during the motion so that the ring
        keeps its partner's orientation about its axis wherever the gripper must grip (the legs
        are never twisted by a member's section orientation: the Figure 8c interference)."""
        other_grips = {'a': (False, True), 'b': (True, False)}[ring]
        out = [self._phase(state, step, PhaseAction.RELEASE, f'ring_{ring}', *other_grips)]
        s0 = state.s_a if ring == 'a' else state.s_b
        world_T_a, world_T_b, angles = self._move_poses(state, ring, target, step)
        if ring == 'a':
            state.s_a, state.theta_a = target, float(angles[-1, 0])
        else:
            state.s_b, state.theta_b = target, float(angles[-1, 1])
        out.append(self._phase(state, step, PhaseAction.MOVE, f'ring_{ring}', *other_grips,
                               world_T_a=world_T_a, world_T_b=world_T_b,
                               s_range=(s0, target, state.s_a, state.s_b), ring_angles=angles))
        out.append(self._phase(state, step, PhaseAction.GRIP, f'ring_{ring}', True, True))
        return out

    def _move_poses(self, state: GaitState, ring: str, target: float, step: int):
        """The sampled world poses (world_T_a, world_T_b) (n, 4, 4) and extra-DOF angles (n, 2) of
        ring ``ring`` moving from ``state`` to route position ``target`` (not checked)."""
        s0 = state.s_a if ring == 'a' else state.s_b
        theta0 = state.theta_a if ring == 'a' else state.theta_b
        wa, wb = self._ring_matrices(state.s_a, state.s_b, state.theta_a, state.theta_b)
        pos, rot = self.structure.swing(s0, target, self.spacing)
        frames = np.zeros((len(pos), 4, 4))
        frames[:, :3, :3], frames[:, :3, 3], frames[:, 3, 3] = rot, pos, 1.0
        theta1 = theta0
        if self.dof:
            ma, mb = self._mount_matrices(theta0, theta0)
            end = frames[-1] @ invert(ma if ring == 'a' else mb)
            theta1 = self._dof_target(ring, theta0, self._twist(end, wb if ring == 'a' else wa), step)
        thetas = np.linspace(theta0, theta1, len(frames))
        if ring == 'a':
            world_T_a = frames @ invert(self._mount_matrices(thetas, state.theta_b)[0])
            world_T_b = np.broadcast_to(wb, world_T_a.shape)
            angles = np.column_stack([thetas, np.full_like(thetas, state.theta_b)])
        else:
            world_T_b = frames @ invert(self._mount_matrices(state.theta_a, thetas)[1])
            world_T_a = np.broadcast_to(wa, world_T_b.shape)
            angles = np.column_stack([np.full_like(thetas, state.theta_a), thetas])
        return world_T_a, world_T_b, angles

    def _place(self, s: float, s0: float, partner: float, step: int, ring: str) -> float:
        """A grip position for a ring moving from ``s0`` towards ``s``: ``s`` itself if allowed,
        else the edge of the forbidden zone nearest to it that still makes progress and keeps
        the partner within reach (a beam junction is stepped over or approached)."""
        s = min(max(s, 0.0), self.structure.length)
        if self.structure.grip_allowed(s):
            return s
        lo_sep, hi_sep = self.reach
        edges = sorted({e for zone in self.structure.forbidden for e in zone}, key=lambda e: abs(e - s))
        for e in edges:
            sep = (e - partner) if ring == 'b' else (partner - e)
            progress = (e - s0) * np.sign(s - s0) > 1e-9
            if progress and 0.0 <= e <= self.structure.length and lo_sep <= sep <= hi_sep:
                return float(e)
        raise PlanError(f'step {step}, phase move_{ring}: grip: no grip position near s={s:.3f} m '
                        f'outside the junction zones within reach', limit=PlanLimit.GRIP, step=step,
                        phase=f'move_{ring}')

    def _step(self, state: GaitState, step: int, d: float, sep_lo: float, up: bool) -> list[Phase]:
        """The leading ring moves by ``d`` (or to a junction zone's edge), the trailing ring
        follows to the contracted separation ``sep_lo`` behind it; to the closest separation
        of the reach (plus 15 % of its range) when the leader's next step must jump a zone."""
        sign = 1.0 if up else -1.0
        lead, trail = ('b', 'a') if up else ('a', 'b')
        close = self.reach[0] + 0.15 * (self.reach[1] - self.reach[0])
        s = {'a': state.s_a, 'b': state.s_b}
        out = self._move(state, step, lead, self._place(s[lead] + sign * d, s[lead], s[trail], step, lead))
        s_lead = state.s_b if up else state.s_a
        follow = close if not self.structure.grip_allowed(s_lead + sign * d) else sep_lo
        out += self._move(state, step, trail, self._place(s_lead - sign * follow, s[trail], s_lead, step, trail))
        return out

    # --- public ---------------------------------------------------------------------------------

    def approach(self, a_T_b: Pose, s_a: float, s_b: float, theta_a: float = 0.0,
                 theta_b: float = 0.0) -> list[Phase]:
        """Phases (step 0) that bring ring_b from a measured pose ``a_T_b`` to its grip at route
        position ``s_b`` while ring_a grips at ``s_a``: release_b, move_b (straight line and
        slerp, every sample checked), grip_b. For a robot that was moved off the gait (by
        teleoperation) before a climb starts. Raises PlanError like ``plan``."""
        state = GaitState(s_a, s_b, theta_a, theta_b)
        wa, wb = self._ring_matrices(s_a, s_b, theta_a, theta_b)
        target = invert(wa) @ wb
        a_T_b = a_T_b.matrix
        angle = math.degrees(rotation_angle_between(a_T_b[:3, :3], target[:3, :3]))
        n = max(int(math.ceil(np.linalg.norm(target[:3, 3] - a_T_b[:3, 3]) / self.spacing)),
                int(math.ceil(angle)), 1) + 1
        p, rot = interpolate_frames(a_T_b[:3, 3], a_T_b[:3, :3], target[:3, 3], target[:3, :3], n)
        path = np.array([transform(pi, Ri) for pi, Ri in zip(p, rot)])
        world_T_a = np.broadcast_to(wa, path.shape)
        world_T_b = wa @ path
        phases = [self._phase(state, 0, PhaseAction.RELEASE, 'ring_b', True, False,
                              world_T_a=world_T_a[:1], world_T_b=world_T_b[:1]),
                  self._phase(state, 0, PhaseAction.MOVE, 'ring_b', True, False,
                              world_T_a=world_T_a, world_T_b=world_T_b),
                  self._phase(state, 0, PhaseAction.GRIP, 'ring_b', True, True)]
        for ph, wb in zip(phases, (world_T_b[0], world_T_b[-1], world_T_b[-1])):
            ph.world_T_a, ph.world_T_b = Pose.from_matrix(wa), Pose.from_matrix(wb)
        time_phases(self.geometry, phases, self.loads)
        return phases


    def plan(self, distance: float, steps: int | None = None, *, start: float | None = None,
             initial_separation: float | None = None, initial_theta: float = 0.0) -> ClimbPlan:
        """A checked plan climbing ``distance`` [m] along the route (negative: down), from ring_a
        at route position ``start`` (default: as low as both rings fit on the route) with ring_b
        ``initial_separation`` ahead of it (default: the home pose; step 0 then brings ring_b to
        the contracted separation), both extra-DOF angles ``initial_theta`` [rad]. Raises
        PlanError when a limit would break, ValueError on bad input."""
        if not math.isfinite(distance) or distance == 0.0:
            raise ValueError(f'distance must be finite and non-zero, got {distance}')
        if steps is None:
            steps = max(int(math.ceil(abs(distance) / self.default_step)), 1)
        if isinstance(steps, bool) or int(steps) != steps or steps < 1:
            raise ValueError(f'steps must be a positive integer, got {steps}')
        steps = int(steps)
        d = abs(distance) / steps
        up = distance > 0.0
        mid = 0.5 * (self.reach[0] + self.reach[1])
        sep_lo = mid - 0.5 * d
        sep0 = self.sep_home if initial_separation is None else float(initial_separation)
        start = self.structure.check_s(max(0.0, -sep0, -sep_lo) if start is None else start)
        s_end = start + distance
        top = max(start + sep0, s_end + mid + 0.5 * d) if up else start + sep0
        bottom = s_end if not up else start
        if bottom < -1e-9 or top > self.structure.length + 1e-9:
            raise ValueError(f'a climb of {distance:.3f} m from s={start:.3f} m leaves the '
                             f'{self.structure.name} (route 0 .. {self.structure.length:.3f} m)')
        state = GaitState(start, self.structure.check_s(start + sep0), initial_theta, initial_theta)
        phases = [self._phase(state, 0, PhaseAction.START, '', True, True)]
        if abs(sep0 - sep_lo) > 1e-9:
            phases += self._move(state, 0, 'b', start + sep_lo)
        for k in range(1, steps + 1):
            phases += self._step(state, k, d, sep_lo, up)
        return self._chain(phases, d, steps)

    def _chain(self, phases: list[Phase], step_length: float, steps: int) -> ClimbPlan:
        """The checked phases as a plan: the gripper interlock, then the rings' world poses
        chained by the odometry."""
        check_interlock(phases)
        odo = None
        for ph in phases:
            ma, mb = self.mounts(ph.theta_a, ph.theta_b)
            if odo is None:
                wa, _ = self.world_rings(ph.s_a, ph.s_b, ph.theta_a, ph.theta_b)
                odo = RingOdometry(wa, ph.a_T_b, a_T_grip=ma, b_T_grip=mb)
            else:
                odo.update(ph.a_T_b, ph.gripper_a, ph.gripper_b, a_T_grip=ma, b_T_grip=mb)
            ph.world_T_a, ph.world_T_b = odo.world_T_a, odo.world_T_b
        time_phases(self.geometry, phases, self.loads)
        return ClimbPlan(robot=self.geometry.name, structure=self.structure.name, step_length=step_length,
                         steps=steps, phases=phases)


def plan_climb(geometry: RobotGeometry, structure: Structure, distance: float, steps: int | None = None,
               **kwargs) -> ClimbPlan:
    """Shortcut: ``GaitPlanner(geometry, structure, ...).plan(distance, steps, ...)``; planner
    options (use_extra_dof, spacing, step_fraction, loads) and plan options (start,
    initial_separation) are both accepted."""
    planner_keys = {'use_extra_dof', 'spacing', 'step_fraction', 'loads'}
    planner = GaitPlanner(geometry, structure, **{k: v for k, v in kwargs.items() if k in planner_keys})
    return planner.plan(distance, steps, **{k: v for k, v in kwargs.items() if k not in planner_keys})
