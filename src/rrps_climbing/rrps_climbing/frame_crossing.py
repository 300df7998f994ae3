"""The frame-node manoeuvre (§3.1, Figs. 8-9): crossing a junction from a column to a member bent
by 1-90 deg, in the column's web plane or out of it.

The grippers clamp beam faces normal to both beams; the extra ring DOF cancels the turn between
them (the Fig. 8c interference). The crossing is searched over every candidate, each pose checked
against eq. 1's limits, beam clearance, actuator forces and holding; the best smallest margin wins,
else PlanError names what blocks which phase. Design and search: docs/frame_node.md. No ROS import.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np

from rrps_climbing.gait import GaitPlanner, GaitState
from rrps_climbing.plan import ClimbPlan, PlanError, PlanLimit
from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import matrix_to_quat_xyzw, rotation_angle_between
from rrps_description.structures import BeamFrame, Structure, interpolate_frames, make_structure
from rrps_interfaces.climb import PhaseAction
from rrps_kinematics import inverse_kinematics, margins
from rrps_kinematics.limits import segment_distances
from rrps_kinematics.odometry import invert
from rrps_loads.loads import holding_margin, static_solution

__all__ = ['BeamFace', 'Candidate', 'Crossing', 'FrameNodePlanner', 'LIMITS', 'SCALES']

#: every limit a candidate is checked against, in the order a refusal names them
LIMITS = ('stroke', 'universal', 'spherical', 'interference', 'conditioning', 'clearance',
          'actuator_force', 'holding')
#: the margin of each limit that scores 1 (m, rad, dimensionless) when candidates are compared
SCALES = {'stroke': 0.05, 'universal': 0.1, 'spherical': 0.1, 'interference': 0.05,
          'conditioning': 0.02, 'clearance': 0.05, 'actuator_force': 0.2, 'holding': 0.2}
_OFFSETS = (0.0, 0.05, 0.1, 0.15)           # stance before the node: off the gusset zone [m]
_PAST = (0.0, 0.05, 0.1, 0.15, 0.2)         # grip points past the node: off the gusset zone [m]
_LIFTS = (0.03, 0.08)                       # lift of the open gripper off the face [m]


class BeamFace(Structure):
    """The route of a :class:`BeamFrame` with a bend, followed on the beams' face of outward normal
    ``side * n`` (n = beam 1 x beam 2): grip frames with z = that normal and x along the route,
    ``ring_height`` above the face; an open gripper lifts by ``lift``, moves while turning, sets
    down. ``capsules``: the beams at the node, ``reach`` long, of the section's circumradius;
    ``obstacles``: those off the route (the route's beams lie a ring height below any gripper)."""

    kind = 'surface'

    def __init__(self, frame: BeamFrame, side: int, *, ring_height: float = 0.1, lift: float = 0.05,
                 reach: float = 1.5):
        z1, z2 = frame.grip_frame(0.0)[1][:, 2], frame.grip_frame(frame.length)[1][:, 2]
        n = np.cross(z1, z2)
        if len(frame.junctions) != 1 or np.linalg.norm(n) < 1e-6:
            raise ValueError('a frame node needs a route of two beams at an angle')
        self.frame, self.side, self.lift = frame, int(side), float(lift)
        self.name, self.length, self.forbidden = frame.name, frame.length, frame.forbidden
        self.junction = frame.junctions[0]
        self.normal = self.side * n / np.linalg.norm(n)
        self.offset = frame.half_width + float(ring_height)
        node = frame.grip_frame(self.junction)[0]
        route = {frozenset(pair) for pair in zip(frame.route[:-1], frame.route[1:])}
        ends, crossing = [], []
        for a, b in frame.beams:  # from the node out, at most ``reach`` long
            p0, p1 = frame.nodes[a], frame.nodes[b]
            if np.linalg.norm(p1 - node) < np.linalg.norm(p0 - node):
                p0, p1 = p1, p0
            ends.append((p0, p0 + (p1 - p0) * min(1.0, reach / np.linalg.norm(p1 - p0))))
            crossing.append(frozenset((a, b)) not in route)
        radius = math.sqrt(2.0) * frame.half_width
        #: the beams near the node as capsules: (starts (K, 3), ends (K, 3), radius [m])
        self.capsules = (np.array([e[0] for e in ends]), np.array([e[1] for e in ends]), radius)
        #: the same for the beams framing into the node off the route (the gripper posts' obstacles)
        self.obstacles = (self.capsules[0][crossing], self.capsules[1][crossing], radius)

    def grip_frame(self, s: float):
        p, R = self.frame.grip_frame(s)
        x = R[:, 2]
        return p + self.offset * self.normal, np.column_stack([x, np.cross(self.normal, x), self.normal])

    def swing(self, s0: float, s1: float, spacing: float = 0.01):
        """Lift, move, set down; the gripper turns evenly over the whole swing (about n)."""
        p0, R0 = self.grip_frame(s0)
        p1, R1 = self.grip_frame(s1)
        up = self.lift * self.normal
        corners = [p0, p0 + up, p1 + up, p1]
        pts = [p0]
        for k, (a, b) in enumerate(zip(corners[:-1], corners[1:])):
            m = max(int(math.ceil(np.linalg.norm(b - a) / spacing)), 1)
            if k == 1:
                m = max(m, int(math.ceil(math.degrees(rotation_angle_between(R0, R1)))))
            pts.append(a + (b - a) * (np.arange(1, m + 1) / m)[:, None])
        pts = np.vstack(pts)
        return pts, interpolate_frames(p0, R0, p1, R1, len(pts))[1]

    def mesh(self):
        return self.frame.mesh()


@dataclass(frozen=True)
class Candidate:
    """One crossing: the face side (+1/-1), ring_a's and ring_b's stance ``s_pre`` before the
    node, ring_b's and ring_a's grip points ``s_b``, ``s_a`` past it [m] and the swing's lift [m]."""

    side: int
    s_pre: float
    s_b: float
    s_a: float
    lift: float


@dataclass
class Crossing:
    """The searched crossing: its candidate, its score (smallest scaled margin), the candidates
    evaluated, and per motion phase the smallest margin of each limit (``LIMITS``), with the
    peak actuator force [N] and its leg."""

    candidate: Candidate
    score: float
    evaluated: int
    margins: dict
    peak_force: dict


class FrameNodePlanner(GaitPlanner):
    """Plans ``geometry`` across a frame node bent by ``junction_deg`` (in the web plane, or
    ``out_of_plane``). The search runs at construction: ``crossing`` holds its result, or
    ``refusal`` the PlanError that :meth:`plan` raises. ``frame``: a frame with one node (a route's)
    instead of the shipped one; ``start_theta``: both extra-DOF angles at the stance [rad]."""

    def __init__(self, geometry: RobotGeometry, junction_deg: float, out_of_plane: bool = False, *,
                 use_extra_dof: bool = True, spacing: float = 0.01, ring_height: float = 0.1,
                 gravity=None, batched: bool = True, frame: BeamFrame | None = None, sides=(1, -1),
                 start_theta: float = 0.0):
        if not (math.isfinite(junction_deg) and 1.0 <= junction_deg <= 90.0):
            raise ValueError(f'junction_deg must be in 1 .. 90 deg, got {junction_deg!r}')
        self.frame = frame or make_structure('frame', junction_deg=junction_deg, out_of_plane=out_of_plane)
        self.faces = {side: BeamFace(self.frame, side, ring_height=ring_height) for side in (1, -1)}
        self.sides, self.start_theta = tuple(sides), float(start_theta)
        # forces and holding are searched at every pose below, with the beam-face clamp's model
        super().__init__(geometry, self.faces[1], use_extra_dof=use_extra_dof, spacing=spacing, loads=None)
        self.dof = use_extra_dof and {'ring_a', 'ring_b'} <= set(geometry.extra_dof)
        self.junction_deg, self.out_of_plane = float(junction_deg), bool(out_of_plane)
        self.gravity = gravity
        self.crossing: Crossing | None = None
        self.refusal: PlanError | None = None
        self._theta_b: dict = {}  # ring_b's angle after a candidate's move_b, during a search
        try:
            self.crossing = self.search(batched=batched)
            self._use(self.crossing.candidate.side, self.crossing.candidate.lift)
        except PlanError as exc:
            self.refusal = exc
            self._use(self.sides[0], _LIFTS[0])

    @property
    def title(self) -> str:
        return (f'{self.junction_deg:g} deg node {"out of" if self.out_of_plane else "in"} plane, '
                f'{"with" if self.dof else "without"} the extra DOF')

    def _use(self, side: int, lift: float) -> None:
        self.structure = self.faces[side]
        self.structure.lift = lift

    # --- checking a batch of poses against every limit -------------------------------------------

    def _evaluate(self, world_T_a: np.ndarray, world_T_b: np.ndarray, support: str, theta: float) -> dict:
        """Per pose (n,), the smallest margin of each limit (``LIMITS``) and the peak force and its
        leg; ``support``: the gripping ring (its attitude: the first pose's), ``theta`` its
        extra-DOF angle [rad]."""
        g = self.geometry
        path = invert(world_T_a) @ world_T_b
        q = matrix_to_quat_xyzw(path[:, :3, :3])
        m = margins(g, inverse_kinematics(g, path[:, :3, 3], q))
        out = {k: np.min(np.asarray(getattr(m, k)), axis=1) for k in ('stroke', 'universal', 'spherical',
                                                                         'interference')}
        out['conditioning'] = np.asarray(m.conditioning, dtype=float)
        out['clearance'] = np.minimum(np.min(self._clearance(world_T_a, world_T_b, None), axis=1),
                                      self._post_clearance(world_T_a, world_T_b))
        ring_T = world_T_a if support == 'ring_a' else world_T_b
        sol = static_solution(g, (path[:, :3, 3], q), support=support, gravity=self.gravity,
                              world_q_support=matrix_to_quat_xyzw(ring_T[0, :3, :3]))
        force = np.abs(sol.actuator_forces)
        out['actuator_force'] = 1.0 - np.max(force, axis=1) / g.max_force
        out['force_leg'] = np.argmax(force, axis=1)
        out['peak_force'] = np.max(force, axis=1)
        out['holding'] = self._holding(sol.support_wrench, support, theta)
        return out

    def _clearance(self, world_T_a, world_T_b, s_range):
        """Distance of every leg segment to every beam at the node minus the beam's circumradius
        and the leg radius, (n, 6)."""
        g = self.geometry
        A = np.einsum('nij,kj->nki', world_T_a[:, :3, :3], g.ring_a_anchors) + world_T_a[:, None, :3, 3]
        B = np.einsum('nij,kj->nki', world_T_b[:, :3, :3], g.ring_b_anchors) + world_T_b[:, None, :3, 3]
        q0, q1, radius = self.structure.capsules
        d = segment_distances(A[:, :, None], B[:, :, None], q0[None, None], q1[None, None])
        return np.min(d, axis=-1) - radius - g.leg_radius

    def _post_clearance(self, world_T_a, world_T_b):
        """Distance of ring_b's gripper post (from ring_b down to ring_a's height above the face,
        as thick as a leg) to every beam framing into the node, minus the beam's circumradius and
        the post's radius, (n,). ring_a's gripper, ``ring_height`` tall below its ring, lies within
        what the legs' check keeps clear."""
        q0, q1, radius = self.structure.obstacles
        if len(q0) == 0:  # a route's node: no beam frames into it off the route
            return np.full(len(world_T_b), np.inf)
        mb = self._mount_matrices(0.0, 0.0)[1]
        top = world_T_b[:, :3, 3]
        foot = top + np.einsum('nij,j->ni', world_T_b[:, :3, :3], mb[:3, 3])
        d = segment_distances(top[:, None], foot[:, None], q0[None], q1[None])
        return np.min(d, axis=-1) - radius - self.geometry.leg_radius

    def _holding(self, wrench: np.ndarray, support: str, theta: float) -> np.ndarray:
        """Holding margin of the gripping ring's clamp from the support wrench (the structure on
        the ring, about its origin). A friction clamp on a beam's flanges: friction carries the
        force along the beam and the moment about the face normal at the clamped section,
        sqrt(F_x² + (M_z / r)²) <= μ N in the grip frame; the section's shape carries the rest.
        Rated limits: ``rrps_loads.loads.holding_margin`` at the clamped section."""
        capacity = self.geometry.holding.get(support)
        if capacity is None:
            return np.ones(len(wrench))
        ma, mb = self._mount_matrices(theta, theta)
        mount = ma if support == 'ring_a' else mb
        o = mount[:3, 3] - self.structure.offset * mount[:3, 2]          # the clamped section
        f, m = wrench[:, :3], wrench[:, 3:] - np.cross(o, wrench[:, :3])
        if capacity.kind != 'friction':
            return holding_margin(dataclasses.replace(capacity, contact=np.zeros(3)), np.hstack([f, m]))
        demand = np.hypot(f @ mount[:3, 0], (m @ mount[:3, 2]) / capacity.radius)
        return 1.0 - demand / (capacity.friction * capacity.clamp_force)

    # --- the search ------------------------------------------------------------------------------

    def _stance(self, side: int) -> list[float]:
        lo = self.faces[side].forbidden[0][0]
        return [lo - e for e in _OFFSETS]

    def _motion(self, c: Candidate, ring: str):
        """(world_T_a, world_T_b, support, support's angle, ring angles) of the candidate's move."""
        self._use(c.side, c.lift)
        state = GaitState(c.s_pre, c.s_pre, self.start_theta, self.start_theta)
        if ring == 'b':
            wa, wb, angles = self._move_poses(state, 'b', c.s_b, 1)
            return wa, wb, 'ring_a', self.start_theta, angles
        key = (c.side, c.s_pre, c.s_b, c.lift)
        if key not in self._theta_b:  # ring_b's angle after its move (the same for every s_a)
            self._theta_b[key] = float(self._move_poses(state, 'b', c.s_b, 1)[2][-1, 1])
        theta_b = self._theta_b[key]
        state.s_b, state.theta_b = c.s_b, theta_b
        wa, wb, angles = self._move_poses(state, 'a', c.s_a, 1)
        return wa, wb, 'ring_b', theta_b, angles

    def _score(self, candidates: list[Candidate], ring: str, batched: bool) -> list[dict]:
        """Each candidate's move of ``ring``: per limit its smallest margin over the motion, its
        score and the peak force; a candidate whose DOF range refuses the move scores -inf."""
        motions, results = [], [None] * len(candidates)
        for i, c in enumerate(candidates):
            try:
                motions.append((i, self._motion(c, ring)))
            except PlanError as exc:
                results[i] = {'score': -math.inf, 'limit': exc.limit.value}
        groups = {}
        for i, mo in motions:  # one batch per support attitude and angle (the face side)
            key = (candidates[i].side, mo[2], round(mo[3], 12)) if batched else i
            groups.setdefault(key, []).append((i, mo))
        for items in groups.values():
            wa = np.concatenate([mo[0] for _, mo in items])
            wb = np.concatenate([mo[1] for _, mo in items])
            self._use(candidates[items[0][0]].side, candidates[items[0][0]].lift)
            ev = self._evaluate(wa, wb, items[0][1][2], items[0][1][3])
            k0 = 0
            for i, mo in items:
                sl = slice(k0, k0 + len(mo[0]))
                k0 = sl.stop
                mins = {k: float(np.min(ev[k][sl])) for k in LIMITS}
                mins = {k: (v if math.isfinite(v) else -math.inf) for k, v in mins.items()}
                worst = min(LIMITS, key=lambda k: mins[k] / SCALES[k])
                j = sl.start + int(np.argmax(ev['peak_force'][sl]))
                results[i] = {'score': mins[worst] / SCALES[worst], 'limit': worst, 'margins': mins,
                              'total': sum(min(mins[k] / SCALES[k], 10.0) for k in LIMITS),
                              'peak_force': (float(ev['peak_force'][j]), int(ev['force_leg'][j]) + 1)}
        return results

    def search(self, batched: bool = True) -> Crossing:
        """The best crossing (see the module docstring); PlanError naming the limit and the phase
        when no candidate keeps every limit."""
        self._theta_b = {}
        firsts = [(side, s_pre, lift) for side in self.sides for s_pre in self._stance(side) for lift in _LIFTS]
        past = [self.faces[1].forbidden[0][1] + e for e in _PAST]
        stage_b = [Candidate(side, s_pre, s_b, math.nan, lift) for (side, s_pre, lift), s_b
                   in itertools.product(firsts, past)]
        res_b = self._score(stage_b, 'b', batched)
        ok_b = [c for c, r in zip(stage_b, res_b) if r['score'] >= 0.0]
        if not ok_b:
            self._refuse('move_b', stage_b, res_b)
        stage_a = [dataclasses.replace(c, s_a=s_a) for c in ok_b for s_a in past]
        res_a = self._score(stage_a, 'a', batched)
        by_b = {c: r for c, r in zip(stage_b, res_b)}
        best, best_key = None, (-math.inf, -math.inf)
        for c, r in zip(stage_a, res_a):  # the largest smallest margin, then the largest sum
            rb = by_b[dataclasses.replace(c, s_a=math.nan)]
            key = (min(r['score'], rb['score']), r['total'] + rb['total'])
            if r['score'] >= 0.0 and key > best_key:
                best, best_key = (c, r), key
        best_score = best_key[0]
        if best is None:
            self._refuse('move_a', stage_a, res_a)
        c, r = best
        rb = by_b[dataclasses.replace(c, s_a=math.nan)]
        return Crossing(candidate=c, score=best_score, evaluated=len(stage_b) + len(stage_a),
                        margins={'move_b': rb['margins'], 'move_a': r['margins']},
                        peak_force={'move_b': rb['peak_force'], 'move_a': r['peak_force']})

    def _refuse(self, phase: str, candidates: list[Candidate], results: list[dict]):
        tally = {}
        for r in results:
            tally[r['limit']] = tally.get(r['limit'], 0) + 1
        i = int(np.argmax([r['score'] for r in results]))
        c, r = candidates[i], results[i]
        ring = phase[-1]
        where = (f'face {"+" if c.side > 0 else "-"}n, stance s={c.s_pre:.3f} m, ring_b past the node '
                 f'at s={c.s_b:.3f} m' + (f', ring_a at s={c.s_a:.3f} m' if ring == 'a' else '')
                 + f', lift {c.lift:.2f} m')
        at = '' if 'margins' not in r else f' ({r["limit"]} margin {r["margins"][r["limit"]]:.4f})'
        counts = ', '.join(f'{k} {n}' for k, n in sorted(tally.items(), key=lambda kv: -kv[1]))
        raise PlanError(f'{self.title}: phase {phase} (ring_{ring} over the node): none of '
                        f'{len(candidates)} candidates keeps every limit; {r["limit"]} blocks the '
                        f'closest ({where}){at}; blocking limits: {counts}',
                        limit=PlanLimit(r['limit']), step=1, phase=phase, margins=r.get('margins'))

    # --- the plan -------------------------------------------------------------------------------

    def plan(self, distance: float, steps: int | None = None, *, start: float | None = None,
             initial_separation: float | None = None, initial_theta: float = 0.0) -> ClimbPlan:
        """A climb up from the searched stance before the node (``start`` None or it, both grippers
        side by side) is the crossing, whatever ``distance`` (one step); other climbs walk a beam
        face (:meth:`GaitPlanner.plan`) and may not enter the node's zone. Raises the search's
        PlanError when the node cannot be crossed."""
        if self.crossing is None:
            raise self.refusal
        c = self.crossing.candidate
        start = c.s_pre if start is None else float(start)
        sep = 0.0 if initial_separation is None else float(initial_separation)
        if distance > 0.0 and abs(start - c.s_pre) < 1e-6 and abs(sep) < 1e-6 \
                and abs(initial_theta - self.start_theta) < 1e-9:
            return self.plan_crossing()
        lo, hi = self.structure.forbidden[0]
        ends = sorted((start, start + sep, start + distance, start + sep + distance))
        if ends[0] < hi and ends[-1] > lo:
            raise ValueError(f'the node is crossed from ring_a and ring_b side by side at s={c.s_pre:.3f} m; '
                             f'climb there first (this climb spans {ends[0]:.3f} .. {ends[-1]:.3f} m)')
        return super().plan(distance, steps, start=start, initial_separation=sep, initial_theta=initial_theta)

    def plan_crossing(self) -> ClimbPlan:
        """The searched crossing as checked phases: start, then step 1: release_b, move_b, grip_b,
        release_a, move_a, grip_a."""
        if self.crossing is None:
            raise self.refusal
        c = self.crossing.candidate
        self._use(c.side, c.lift)
        state = GaitState(c.s_pre, c.s_pre, self.start_theta, self.start_theta)
        phases = [self._phase(state, 0, PhaseAction.START, '', True, True)]
        phases += self._move(state, 1, 'b', c.s_b)
        phases += self._move(state, 1, 'a', c.s_a)
        return self._chain(phases, c.s_a - c.s_pre, 1)
