"""Loads as limits of a climbing plan: every phase during which one gripper holds (release and
move of the other ring) is checked along its path with :mod:`rrps_loads.path_loads` (one batch
for all the phases one ring holds at one attitude), quasi-static plus the accelerations of the
phase's timing law (:class:`PhasePath` at ``speed``), in the world gravity of the holding
ring's attitude (the plan's odometry, the structure turned by ``world_q_structure`` in the
world). A phase where an actuator force exceeds the robot's
``max_force`` or the holding gripper's margin falls below zero is refused with a
:class:`PlanError` naming the limit, the leg or ring, and where (step, phase, pose, fraction of
the phase). Hand-over phases (both grippers closed) are not checked: the split of the load
between two grippers is statically indeterminate; their pose ends the checked motion before.

Pure NumPy; no ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rrps_climbing.phase_path import PhasePath
from rrps_climbing.plan import Phase, PhaseLoads, PlanError, PlanLimit
from rrps_description.geometry import RobotGeometry
from rrps_description.rotations import quat_multiply_xyzw
from rrps_description.world import IDENTITY_QUATERNION, STANDARD_GRAVITY, Support
from rrps_loads.path_loads import ACTUATOR_FORCE, LoadViolation, PathLoads, first_violation, loads_at, path_twists

__all__ = ['LoadCheck', 'DEFAULT_SPEED']

#: The speed [m/s] a plan's motions are checked at: the climb step machine's default.
DEFAULT_SPEED = 0.02


@dataclass(frozen=True)
class LoadCheck:
    """How a plan's loads are checked: motions streamed at ``speed`` [m/s], the structure turned
    by ``world_q_structure`` (x, y, z, w) in a world of ``gravity`` (3,) [m/s²]. The payload and
    tool wrench are the robot's (``RobotGeometry.payload``, ``tool_wrench``)."""

    speed: float = DEFAULT_SPEED
    world_q_structure: tuple = IDENTITY_QUATERNION
    gravity: tuple = STANDARD_GRAVITY

    def __post_init__(self) -> None:
        if not (isinstance(self.speed, (int, float)) and math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError(f'speed: must be a positive finite number [m/s], got {self.speed!r}')
        Support.of('ring_a', self.world_q_structure, self.gravity)   # ValueError if invalid

    def _timed(self, geometry: RobotGeometry, ph: Phase) -> _Timed:
        """A held phase timed at ``speed`` and differentiated."""
        ring = 'ring_a' if ph.gripper_a else 'ring_b'
        world_T_ring = ph.world_T_a if ring == 'ring_a' else ph.world_T_b
        q = quat_multiply_xyzw(np.asarray(self.world_q_structure, dtype=float), world_T_ring.quaternion_xyzw)
        timed = PhasePath(ph.path, ph.ring_angles, speed=self.speed,
                          characteristic_length=geometry.characteristic_length)
        t = timed.times
        kept = np.flatnonzero(np.concatenate([[True], np.diff(t) > 1e-12]))
        fractions = t[kept] / t[-1] if t[-1] > 0.0 else np.zeros(len(kept))
        motion = path_twists(t[kept], ph.path[kept, :3, 3], timed.quaternions_xyzw[kept])
        return _Timed(ring, q / np.linalg.norm(q), kept, fractions, motion)

    def _loads(self, geometry: RobotGeometry, timed: list[_Timed]) -> list[PathLoads]:
        """The loads of timed phases, one :func:`loads_at` for all the phases one ring holds at
        one attitude (an attitude within 1e-9 counts as the same)."""
        groups: dict[tuple, list[int]] = {}
        for i, x in enumerate(timed):
            groups.setdefault((x.ring, *np.round(x.world_q, 9)), []).append(i)
        out: list[PathLoads | None] = [None] * len(timed)
        for members in groups.values():
            parts = [timed[i].motion for i in members]
            loads = loads_at(geometry, *(np.concatenate(arrays) for arrays in zip(*parts)),
                             support=timed[members[0]].ring, world_q_support=timed[members[0]].world_q,
                             gravity=self.gravity)
            cuts = np.cumsum([len(m[0]) for m in parts])[:-1]
            pieces = (np.split(a, cuts) for a in (loads.actuator_forces, loads.support_wrench, loads.holding_margin))
            for i, *fields in zip(members, *pieces):
                out[i] = PathLoads(loads.support, *fields)
        return out

    def phase_loads(self, geometry: RobotGeometry, ph: Phase) -> tuple[PathLoads, np.ndarray, np.ndarray] | None:
        """The loads along a phase during which one gripper holds, the indices in the phase's
        path of their samples (repeated poses once) and their fractions of the phase's duration;
        None for a hand-over."""
        if ph.gripper_a == ph.gripper_b:
            return None
        timed = self._timed(geometry, ph)
        return self._loads(geometry, [timed])[0], timed.kept, timed.fractions

    def check(self, geometry: RobotGeometry, phases) -> None:
        """Check every phase in order and keep its :class:`PhaseLoads` on it (``Phase.loads``);
        raises PlanError (limit ACTUATOR_FORCE or HOLDING) at the first one past a limit. The
        phases' samples are computed in batches (:meth:`_loads`)."""
        held = [ph for ph in phases if ph.gripper_a != ph.gripper_b]
        timed = [self._timed(geometry, ph) for ph in held]
        for ph, x, loads in zip(held, timed, self._loads(geometry, timed)):
            violation = first_violation(geometry, loads)
            if violation is not None:
                raise _refusal(geometry, ph, loads, int(x.kept[violation.sample]),
                               float(x.fractions[violation.sample]), violation)
            ph.loads = PhaseLoads(peak_force=loads.peak_force, peak_leg=f'leg_{loads.peak_leg + 1}',
                                  holding_margin=loads.min_holding_margin, holding_ring=loads.support.ring)


class _Timed(NamedTuple):
    """A held phase timed: the holding ring, its attitude in the world, the indices of the kept
    samples in the phase's path, their fractions of its duration, and (positions, quaternions,
    twists, twist rates) at them (:func:`rrps_loads.path_loads.path_twists`)."""

    ring: str
    world_q: np.ndarray
    kept: np.ndarray
    fractions: np.ndarray
    motion: tuple


def _refusal(geometry: RobotGeometry, ph: Phase, loads: PathLoads, k: int, fraction: float,
             v: LoadViolation) -> PlanError:
    """The PlanError of ``v``, at pose ``k`` of the phase's path (``fraction`` of its duration)."""
    n = len(ph.path)
    position = ', '.join(f'{x:.3f}' for x in ph.path[k, :3, 3])
    force, moment = loads.support_wrench[v.sample, :3], loads.support_wrench[v.sample, 3:]
    if v.limit == ACTUATOR_FORCE:
        detail = f'{v.who} force {v.value:.1f} N exceeds the actuator limit {v.bound:.1f} N'
    else:
        detail = (f'{v.who} holding margin {v.value:.3f} < 0: the gripper slips (reaction force '
                  f'({", ".join(f"{x:.1f}" for x in force)}) N, moment '
                  f'({", ".join(f"{x:.1f}" for x in moment)}) N m in {v.who}\'s frame)')
    where = (f'step {ph.step} {ph.phase}, pose {k + 1}/{n}, fraction {fraction:.2f} of the '
             f'phase, a_T_b at ({position}) m')
    there = {'actuator_force': float(geometry.max_force - np.max(np.abs(loads.actuator_forces[v.sample]))),
             'holding': float(loads.holding_margin[v.sample])}
    return PlanError(f'{v.limit}, {v.who}, {where}: {detail}', limit=PlanLimit(v.limit),
                     legs=() if v.leg is None else (v.who,), ring=v.ring, step=ph.step, phase=ph.phase,
                     pose=k, fraction=fraction, margins={key: x for key, x in there.items() if math.isfinite(x)})
