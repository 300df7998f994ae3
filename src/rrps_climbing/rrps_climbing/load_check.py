"""A plan's timing and loads as limits: each phase gets its duration, each motion its
time-optimal, jerk-limited timing (:mod:`.timing`) within the legs' limits, a speed cap, the force
limit and the holding capacity in the holding ring's world gravity; hand-overs via :mod:`.handover`.

A motion or hand-over that breaks a limit raises :class:`~.plan.PlanError` (the limit, the leg or ring,
where); a speed beyond the legs is capped (:meth:`LoadCheck.capped`), a non-finite or <= 0 one
refused. No ROS import.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rrps_climbing.handover import check_handover
from rrps_climbing.plan import Phase, PhaseLoads
from rrps_climbing.timing import TimedMotion, check_speed, rest_loads, time_motion
from rrps_climbing.timing_constraints import Held
from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_multiply_xyzw
from rrps_description.world import IDENTITY_QUATERNION, STANDARD_GRAVITY, Support
from rrps_interfaces.climb import PhaseAction

__all__ = ['LoadCheck', 'time_phases']


@dataclass(frozen=True)
class LoadCheck:
    """How a plan's loads are checked: motions timed with a path-speed cap ``speed`` [m/s]
    (None: the legs' limits alone), the structure turned by ``world_q_structure`` (x, y, z, w)
    in a world of ``gravity`` (3,) [m/s²]. The payload and tool wrench are the robot's
    (``RobotGeometry.payload``, ``tool_wrench``)."""

    speed: float | None = None
    world_q_structure: tuple = IDENTITY_QUATERNION
    gravity: tuple = STANDARD_GRAVITY

    def __post_init__(self) -> None:
        Support.of('ring_a', self.world_q_structure, self.gravity)   # ValueError if invalid

    def held(self, ph: Phase) -> Held:
        """The ring that holds during ``ph`` (ring_a when both do), its attitude in the world."""
        ring = 'ring_a' if ph.gripper_a else 'ring_b'
        world_T_ring = ph.world_T_a if ring == 'ring_a' else ph.world_T_b
        q = quat_multiply_xyzw(np.asarray(self.world_q_structure, dtype=float), world_T_ring.quaternion_xyzw)
        return Held(ring, tuple(q / np.linalg.norm(q)), tuple(self.gravity))

    def check(self, geometry: RobotGeometry, phases) -> None:
        """Time every phase and check its loads (:func:`time_phases`)."""
        time_phases(geometry, phases, self)

    @staticmethod
    def capped(phases) -> list[Phase]:
        """The motion phases whose requested speed the legs do not reach anywhere."""
        return [ph for ph in phases if isinstance(ph.timing, TimedMotion) and ph.timing.capped]


def _time_motion(geometry: RobotGeometry, ph: Phase, loads: LoadCheck | None) -> TimedMotion:
    return time_motion(geometry, ph.path, ph.ring_angles, speed=None if loads is None else loads.speed,
                       held=None if loads is None else loads.held(ph), where=(ph.step, ph.phase))


def time_phases(geometry: RobotGeometry, phases, loads: LoadCheck | None) -> None:
    """Give each phase its ``duration`` [s] and each motion its ``timing``
    (:class:`~.timing.TimedMotion`); with ``loads``, keep the loads of each phase one gripper
    holds (``Phase.loads``: its timed motion's, a release at rest) and check the hand-overs.
    Raises PlanError at the first phase past a limit (module docstring)."""
    grippers = geometry.motion_limits.grippers
    for ph in phases:
        if ph.action is PhaseAction.MOVE and len(ph.path) > 1:
            ph.timing = _time_motion(geometry, ph, loads)
            ph.duration = ph.timing.duration
        elif ph.action in (PhaseAction.RELEASE, PhaseAction.GRIP):
            check_speed(None if loads is None else loads.speed, ph.step, ph.phase)
            ph.duration = grippers[ph.ring].switch(ph.action is PhaseAction.GRIP)
        else:
            ph.duration = 0.0
        if loads is None:
            continue
        if ph.gripper_a and ph.gripper_b:
            ph.loads = check_handover(geometry, ph, loads.held(ph).world_q, loads.gravity)
        elif ph.timing is not None:
            t = ph.timing.loads
            ph.loads = PhaseLoads(peak_force=t.peak_force, peak_leg=f'leg_{t.peak_leg + 1}',
                                  holding_margin=t.min_holding_margin, holding_ring=t.ring)
        else:
            ph.loads = _at_rest(geometry, ph, loads)


def _at_rest(geometry: RobotGeometry, ph: Phase, loads: LoadCheck) -> PhaseLoads:
    """The loads of a phase one gripper holds without moving (a release)."""
    x = rest_loads(geometry, ph.a_T_b, loads.held(ph), (ph.step, ph.phase))
    return PhaseLoads(peak_force=x.peak_force, peak_leg=f'leg_{x.peak_leg + 1}', holding_margin=x.min_holding_margin,
                      holding_ring=x.ring)
