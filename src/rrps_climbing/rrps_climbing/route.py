"""Routes (§§3.1-3.2): a frame over several nodes bent one way in one plane, up and down, and a
facade round a corner (the gait on :class:`rrps_description.corners.FacadeCorner`, :func:`plan_route`).

On a frame route each node is crossed as :class:`~.frame_crossing.FrameNodePlanner` searches it,
the beams between walked with the gait's moves under the crossing's limits; a route down is the
route up played backwards (:func:`reversed_phases`). A route the limits cannot realise raises
:class:`~.plan.PlanError`. See docs/frame_node.md. No ROS import.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rrps_climbing.frame_crossing import LIMITS, BeamFace, FrameNodePlanner
from rrps_climbing.gait import GaitPlanner, GaitState
from rrps_climbing.plan import ClimbPlan, Phase, PhaseLoads, PlanError, PlanLimit
from rrps_description.corners import facade_corner
from rrps_description.geometry import RobotGeometry
from rrps_description.structures import BeamFrame
from rrps_interfaces.climb import PhaseAction
from rrps_kinematics.odometry import invert

__all__ = ['ROUTES', 'RouteFace', 'FrameRoutePlanner', 'frame_route', 'reversed_phases', 'plan_route']

_EPS = 1e-9


def frame_route(bends_deg=(30.0, 30.0), column: float = 1.6, beam: float = 1.2,
                node_clearance: float = 0.1) -> BeamFrame:
    """A column ``column`` [m] high, then beams ``beam`` [m] long, each bent by the next of
    ``bends_deg`` [deg] further towards +x in the x-z plane (no section twist at the nodes)."""
    points, direction, angle = [np.zeros(3), np.array([0.0, 0.0, column])], None, 0.0
    for bend in bends_deg:
        angle += math.radians(float(bend))
        direction = np.array([math.sin(angle), 0.0, math.cos(angle)])
        points.append(points[-1] + beam * direction)
    names = [f'n{k}' for k in range(len(points))]
    return BeamFrame(dict(zip(names, points)), list(zip(names[:-1], names[1:])), names,
                     node_clearance=node_clearance, name='frame_route')


class RouteFace(BeamFace):
    """The face of normal ``normal`` of every beam of a route with several nodes: grip frames,
    swings and mesh as :class:`~.frame_crossing.BeamFace` (z = the normal, x along the route)."""

    def __init__(self, frame: BeamFrame, normal, *, ring_height: float = 0.1, lift: float = 0.05):
        self.frame, self.lift = frame, float(lift)
        self.name, self.length, self.forbidden = frame.name, frame.length, frame.forbidden
        self.normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
        self.offset = frame.half_width + float(ring_height)


def _node_frame(frame: BeamFrame, k: int) -> tuple[BeamFrame, float, float]:
    """The two beams at the route's interior node ``k`` (0-based) as a frame of their own, in the
    world; the route position of its start and the bend [deg]."""
    names = frame.route[k:k + 3]
    p = [frame.nodes[n] for n in names]
    starts = (0.0,) + frame.junctions
    zone = frame.forbidden[k]
    web = frame.grip_frame(starts[k])[1][:, 0]
    local = BeamFrame({n: frame.nodes[n] for n in names}, list(zip(names[:-1], names[1:])), names, web=web,
                      node_clearance=0.5 * (zone[1] - zone[0]), half_width=frame.half_width, name=frame.name)
    z_in, z_out = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0]), (p[2] - p[1]) / np.linalg.norm(p[2] - p[1])
    return local, starts[k], math.degrees(math.acos(float(np.clip(z_in @ z_out, -1.0, 1.0))))


class FrameRoutePlanner:
    """Plans climbs of ``geometry`` along a frame route (see the module docstring). The crossing
    of every node is searched at construction, bottom up; a node that cannot be crossed raises
    the search's PlanError, naming the node."""

    def __init__(self, geometry: RobotGeometry, frame: BeamFrame, *, use_extra_dof: bool = True, gravity=None,
                 ring_height: float = 0.1):
        self.geometry, self.frame = geometry, frame
        self.nodes: list[tuple[FrameNodePlanner, float]] = []   # (planner, route offset) per node
        self.thetas = [0.0]                                     # extra-DOF angle before each node, and after
        normal = None
        for k in range(len(frame.junctions)):
            local, offset, bend = _node_frame(frame, k)
            sides = (1, -1)
            if normal is not None:
                n = BeamFace(local, 1, ring_height=ring_height).normal
                if abs(n @ normal) < 1.0 - 1e-6:
                    raise ValueError(f'node {k + 1}: a route bends in one plane, one way (its face normal)')
                sides = (1,) if n @ normal > 0.0 else (-1,)
            planner = FrameNodePlanner(geometry, bend, use_extra_dof=use_extra_dof, ring_height=ring_height,
                                       gravity=gravity, frame=local, sides=sides, start_theta=self.thetas[-1])
            if planner.refusal is not None:
                e = planner.refusal
                raise PlanError(f'node {k + 1} of the route at s={frame.junctions[k]:.3f} m: {e}', limit=e.limit,
                                step=e.step, phase=e.phase, margins=e.margins)
            normal = planner.structure.normal
            end = planner.plan_crossing().phases[-1]
            if abs(end.theta_a - end.theta_b) > _EPS:
                raise PlanError(f'node {k + 1}: the rings leave it at different extra-DOF angles',
                                limit=PlanLimit.EXTRA_DOF, step=1, phase='grip_a')
            self.nodes.append((planner, offset))
            self.thetas.append(float(end.theta_a))
        if normal is None:
            raise ValueError('a frame route needs at least one node')
        self.face = RouteFace(frame, normal, ring_height=ring_height)
        self.walker = GaitPlanner(geometry, self.face, use_extra_dof=False, loads=None)
        self.stride = 0.7 * self.walker.reach[1]
        self.reach, self.dof = self.walker.reach, self.nodes[0][0].dof

    def theta_at(self, s: float) -> float:
        """Both extra-DOF angles [rad] of the rings at rest at route position ``s``."""
        return self.thetas[sum(1 for j in self.frame.junctions if j < s)]

    def plan(self, distance: float, *, start: float = 0.3) -> ClimbPlan:
        """A checked climb of ``distance`` [m] along the route (negative: down) from both rings
        side by side at route position ``start``, ending side by side."""
        if not (math.isfinite(distance) and distance != 0.0):
            raise ValueError(f'distance must be finite and non-zero, got {distance}')
        lo, hi = sorted((float(start), float(start) + distance))
        for s in (lo, hi):
            self.face.check_s(s)
            if not self.face.grip_allowed(s):
                raise ValueError(f'route position {s:.3f} m is within a node zone: no gripper closes there')
        phases = self._up(lo, hi)
        if distance < 0.0:
            phases = reversed_phases(phases)
        steps = max(ph.step for ph in phases)
        return self.walker._chain(phases, abs(distance) / steps, steps)

    def _up(self, lo: float, hi: float) -> list[Phase]:
        state = GaitState(lo, lo, self.theta_at(lo), self.theta_at(lo))
        phases = [self.walker._phase(state, 0, PhaseAction.START, '', True, True)]
        step = 1
        for k, (planner, offset) in enumerate(self.nodes):
            junction = self.frame.junctions[k]
            if not lo < junction < hi:
                continue
            c = planner.crossing.candidate
            if lo > c.s_pre + offset + _EPS or hi < max(c.s_a, c.s_b) + offset - _EPS:
                raise PlanError(f'step {step}, phase move_b: node {k + 1} at s={junction:.3f} m is crossed from '
                                f's={c.s_pre + offset:.3f} m to s={max(c.s_a, c.s_b) + offset:.3f} m: the route '
                                f'{lo:.3f} .. {hi:.3f} m starts or ends within that', limit=PlanLimit.GRIP,
                                step=step, phase='move_b')
            step = self._walk(state, c.s_pre + offset, step, phases, planner)
            crossing = planner.crossing
            for ph in planner.plan_crossing().phases[1:]:
                loads = None
                if ph.phase in crossing.margins:  # the search's statics of the motion
                    force, leg = crossing.peak_force[ph.phase]
                    loads = PhaseLoads(force, f'leg_{leg}', crossing.margins[ph.phase]['holding'],
                                       'ring_a' if ph.gripper_a else 'ring_b')
                phases.append(dataclasses.replace(ph, step=step, s_a=ph.s_a + offset, s_b=ph.s_b + offset,
                                                  loads=loads))
            state = GaitState(c.s_a + offset, c.s_b + offset, self.thetas[k + 1], self.thetas[k + 1])
            step += 1
        last = self.nodes[-1][0] if hi > self.frame.junctions[-1] else next(
            p for (p, _), j in zip(self.nodes, self.frame.junctions) if j >= hi)
        self._walk(state, hi, step, phases, last)
        return phases

    def _walk(self, state: GaitState, target: float, step: int, phases: list[Phase],
              planner: FrameNodePlanner) -> int:
        """Both rings up the beam face to side by side at ``target``: ring_b at most ``stride``
        ahead of ring_a, ring_a beside it; each motion checked by ``planner``'s limits too.
        Returns the next step number."""
        while abs(state.s_a - target) > _EPS or abs(state.s_b - target) > _EPS:
            if state.s_b < target - _EPS:
                new = self.walker._move(state, step, 'b', min(target, max(state.s_a, state.s_b) + self.stride))
                self._check(new[1], planner)
                phases += new
            if abs(state.s_a - state.s_b) > _EPS:
                new = self.walker._move(state, step, 'a', state.s_b)
                self._check(new[1], planner)
                phases += new
            step += 1
        return step

    def _check(self, ph: Phase, planner: FrameNodePlanner) -> None:
        """A walking motion against every limit of the node's crossing search (PlanError)."""
        wa, wb = self.walker._ring_matrices(ph.s_a, ph.s_b, ph.theta_a, ph.theta_b)
        support = 'ring_a' if ph.gripper_a else 'ring_b'
        if support == 'ring_a':
            world_T_a, world_T_b, theta = np.broadcast_to(wa, ph.path.shape), wa @ ph.path, ph.theta_a
        else:
            world_T_a, world_T_b, theta = wb @ invert(ph.path), np.broadcast_to(wb, ph.path.shape), ph.theta_b
        margins = planner._evaluate(np.ascontiguousarray(world_T_a), np.ascontiguousarray(world_T_b), support, theta)
        peak = int(np.argmax(margins['peak_force']))
        ph.loads = PhaseLoads(float(margins['peak_force'][peak]), f'leg_{int(margins["force_leg"][peak]) + 1}',
                              float(np.min(margins['holding'])), support)
        for limit in LIMITS:
            worst = int(np.argmin(margins[limit]))
            if not margins[limit][worst] >= 0.0:
                raise PlanError(f'step {ph.step}, phase {ph.phase} (walking the beam face, s_a={ph.s_a:.3f} m, '
                                f's_b={ph.s_b:.3f} m, pose {worst + 1}/{len(ph.path)}): {limit} margin '
                                f'{margins[limit][worst]:.4f}', limit=PlanLimit(limit), step=ph.step,
                                phase=ph.phase, pose=worst, margins={k: float(np.min(margins[k])) for k in LIMITS})


_SWAP = {PhaseAction.RELEASE: PhaseAction.GRIP, PhaseAction.GRIP: PhaseAction.RELEASE,
         PhaseAction.MOVE: PhaseAction.MOVE}


def reversed_phases(phases: list[Phase]) -> list[Phase]:
    """A plan's phases played backwards: a new start where it ended, then each phase undone in
    reverse order (a grip becomes a release and back, a motion runs its path backwards), each
    ending as the phase before it ended (a motion keeps its loads: the same poses); steps
    numbered in the new order."""
    last = phases[-1]
    top = max(ph.step for ph in phases)
    out = [dataclasses.replace(last, step=0, action=PhaseAction.START, ring='', path=last.path[-1:],
                               ring_angles=last.ring_angles[-1:], loads=None)]
    for ph, before in zip(reversed(phases[1:]), reversed(phases[:-1])):
        out.append(dataclasses.replace(
            ph, step=top + 1 - ph.step, action=_SWAP[ph.action], gripper_a=before.gripper_a,
            gripper_b=before.gripper_b, s_a=before.s_a, s_b=before.s_b, theta_a=before.theta_a,
            theta_b=before.theta_b, path=ph.path[::-1].copy(), ring_angles=ph.ring_angles[::-1].copy(),
            lengths=before.lengths))
    return out


#: The shipped routes by name: a structure and how to plan on it.
ROUTES = {'frame_route': 'several frame nodes, up and down (frame climber)',
          'facade_corner': 'a facade around a vertical corner (facade climber)'}


def plan_route(geometry: RobotGeometry, route: str, distance: float, *, start: float | None = None,
               corner_deg: float = 20.0, bends_deg=(30.0, 30.0), use_extra_dof: bool = True,
               loads=None, gravity=None):
    """(planner, plan, structure) of a shipped route (``ROUTES``): ``frame_route`` bent by
    ``bends_deg`` (from ``start``, default 0.3 m), ``facade_corner`` turning ``corner_deg``
    (the gait with ``loads`` and half the reach per step, from ``start``, default 1.5 m: 0.5 m
    before the corner)."""
    if route == 'frame_route':
        planner = FrameRoutePlanner(geometry, frame_route(bends_deg), use_extra_dof=use_extra_dof, gravity=gravity)
        return planner, planner.plan(distance, start=0.3 if start is None else start), planner.face
    if route == 'facade_corner':
        structure = facade_corner(corner_deg)
        kwargs = {} if loads is None else {'loads': loads}
        planner = GaitPlanner(geometry, structure, use_extra_dof=use_extra_dof, step_fraction=0.5, **kwargs)
        return planner, planner.plan(distance, start=1.5 if start is None else start), structure
    raise ValueError(f'unknown route {route!r}: one of {", ".join(ROUTES)}')
