"""A climbing plan: its phases (pose path, grippers, route positions, margins), the gripper
interlock over a phase sequence, and why a plan is refused (:class:`PlanError`, :class:`PlanLimit`).
Pure NumPy; no ROS import.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from rrps_description.pose import Pose
from rrps_interfaces.climb import PhaseAction

__all__ = ['PlanError', 'PlanLimit', 'Phase', 'PhaseLoads', 'ClimbPlan', 'check_interlock', 'MARGIN_KINDS',
           'CSV_COLUMNS']

MARGIN_KINDS = ('stroke', 'universal', 'spherical', 'interference', 'conditioning', 'clearance')


class PlanLimit(str, enum.Enum):
    """What a refused plan breaks: a pose limit (:class:`rrps_kinematics.limits.LimitKind`), the
    legs' clearance to the structure, the gripper interlock, the extra DOF's range, no grip
    position, an actuator's force limit or the holding gripper's capacity
    (:mod:`rrps_climbing.load_check`), a requested speed that is not finite and > 0, no
    timing of a motion within the limits (:mod:`rrps_climbing.timing`) (a str:
    ``PlanLimit.STROKE == 'stroke'``)."""

    STROKE = 'stroke'
    UNIVERSAL = 'universal'
    SPHERICAL = 'spherical'
    INTERFERENCE = 'interference'
    CONDITIONING = 'conditioning'
    CLEARANCE = 'clearance'
    INTERLOCK = 'interlock'
    EXTRA_DOF = 'extra_dof'
    GRIP = 'grip'
    ACTUATOR_FORCE = 'actuator_force'
    HOLDING = 'holding'
    SPEED = 'speed'
    TIMING = 'timing'


CSV_COLUMNS = (['step', 'phase', 'gripper_a', 'gripper_b', 's_a', 's_b',
                'a_x', 'a_y', 'a_z', 'a_qx', 'a_qy', 'a_qz', 'a_qw',
                'b_x', 'b_y', 'b_z', 'b_qx', 'b_qy', 'b_qz', 'b_qw',
                'px', 'py', 'pz', 'qx', 'qy', 'qz', 'qw', 'theta_a', 'theta_b']
               + [f'L{i}' for i in range(1, 7)] + [f'margin_{k}' for k in MARGIN_KINDS]
               + ['peak_force', 'holding_margin', 'duration'])


class PlanError(ValueError):
    """A plan that breaks a limit. ``limit``: a :class:`PlanLimit`; ``legs``: leg names involved;
    ``ring``: the holding ring (HOLDING); ``step``, ``phase``, ``pose`` (index in the phase's
    path) and ``fraction`` (of the phase's duration): where; ``margins``: the smallest margin of
    each kind at the first pose that breaks a limit (empty for non-pose limits)."""

    def __init__(self, message: str, *, limit: PlanLimit, legs=(), ring: str | None = None,
                 step: int | None = None, phase: str | None = None, pose: int | None = None,
                 fraction: float | None = None, margins: dict | None = None):
        super().__init__(message)
        self.margins = dict(margins or {})
        self.limit = PlanLimit(limit)
        self.legs = tuple(legs)
        self.ring = ring
        self.step = step
        self.phase = phase
        self.pose = pose
        self.fraction = fraction


@dataclass(frozen=True)
class PhaseLoads:
    """The loads over a phase during which one gripper holds (:mod:`.load_check`): the largest
    |actuator force| ``peak_force`` [N] and its leg ``peak_leg``, the smallest
    ``holding_margin`` (1 - utilisation; NaN without a capacity) of ``holding_ring``."""

    peak_force: float
    peak_leg: str
    holding_margin: float
    holding_ring: str


@dataclass
class Phase:
    """One phase of a plan; its poses are taken at the end of the phase. ``path``: the sampled a_T_b
    (n, 4, 4), ends included; ``min_margins``: smallest margin of each kind (SI, clearance NaN where
    it does not apply).
    """

    step: int
    action: PhaseAction
    ring: str
    gripper_a: bool
    gripper_b: bool
    s_a: float
    s_b: float
    theta_a: float
    theta_b: float
    path: np.ndarray
    lengths: np.ndarray
    min_margins: dict
    world_T_a: Pose = field(default_factory=Pose)
    world_T_b: Pose = field(default_factory=Pose)
    #: the extra-DOF angles (theta_a, theta_b) [rad] at each sample of ``path`` (n, 2)
    ring_angles: np.ndarray | None = None
    #: the loads over the phase when they were checked (its timed motion's; a hand-over's split)
    loads: PhaseLoads | None = None
    #: how long the phase takes [s] (a motion its timing's, a gripper its switch), once timed
    duration: float = 0.0
    #: a motion's timing law (:class:`rrps_climbing.timing.TimedMotion`), once timed
    timing: object | None = None

    def __post_init__(self) -> None:
        if self.ring_angles is None:
            self.ring_angles = np.tile([self.theta_a, self.theta_b], (len(self.path), 1))

    @property
    def a_T_b(self) -> Pose:
        """The kinematic pose at the end of the phase (the last of ``path``)."""
        return Pose.from_matrix(self.path[-1])

    @property
    def phase(self) -> str:
        """The phase's name: the action, and the ring's letter ('grip_a'); 'start'."""
        return self.action.value + (f'_{self.ring[-1]}' if self.ring else '')

    def row(self) -> dict:
        """One CSV row (see ``CSV_COLUMNS``)."""
        a_T_b = self.a_T_b
        values = [self.step, self.phase, int(self.gripper_a), int(self.gripper_b), self.s_a, self.s_b,
                  *self.world_T_a.position, *self.world_T_a.quaternion_xyzw,
                  *self.world_T_b.position, *self.world_T_b.quaternion_xyzw,
                  *a_T_b.position, *a_T_b.quaternion_xyzw, self.theta_a, self.theta_b, *self.lengths,
                  *(self.min_margins[k] for k in MARGIN_KINDS),
                  *((math.nan, math.nan) if self.loads is None
                    else (self.loads.peak_force, self.loads.holding_margin)), self.duration]
        return dict(zip(CSV_COLUMNS, values))


@dataclass
class ClimbPlan:
    """A checked plan: its phases, the step length [m] and the smallest margins over it."""

    robot: str
    structure: str
    step_length: float
    steps: int
    phases: list

    @property
    def min_margins(self) -> dict:
        return {k: float(np.nanmin([p.min_margins[k] for p in self.phases]))
                if not all(np.isnan(p.min_margins[k]) for p in self.phases) else math.nan
                for k in MARGIN_KINDS}

    @property
    def peak_load(self) -> PhaseLoads | None:
        """The largest actuator force and the smallest holding margin over the checked phases
        (``holding_ring``: the ring at that margin); None when no phase was load-checked."""
        checked = [p.loads for p in self.phases if p.loads is not None]
        if not checked:
            return None
        peak = max(checked, key=lambda x: x.peak_force)
        held = [x for x in checked if not math.isnan(x.holding_margin)]
        low = min(held, key=lambda x: x.holding_margin) if held else peak
        return PhaseLoads(peak_force=peak.peak_force, peak_leg=peak.peak_leg,
                          holding_margin=low.holding_margin if held else math.nan,
                          holding_ring=low.holding_ring)

    @property
    def duration(self) -> float:
        """How long the plan takes [s]: its motions' timings and its grippers' switches."""
        return float(sum(p.duration for p in self.phases))

    def step_durations(self) -> dict[int, float]:
        """Each step's duration [s] (step 0: bringing ring_b to the gait's first stance)."""
        out: dict[int, float] = {}
        for p in self.phases:
            out[p.step] = out.get(p.step, 0.0) + p.duration
        return out

    @property
    def climbing_speed(self) -> float:
        """Route distance climbed per minute [m/min] over the steps 1.. (step 0 excluded)."""
        steps = sum(d for k, d in self.step_durations().items() if k >= 1)
        return 60.0 * abs(self.climbed) / steps if steps > 0.0 else math.nan

    @property
    def step_timing(self) -> tuple[float, float]:
        """The longest step's duration [s] (steps 1..) and the climbing speed [m/min]."""
        return max(d for k, d in self.step_durations().items() if k >= 1), self.climbing_speed

    def describe(self) -> str:
        """The plan in words: its steps, phases and timing."""
        return (f'{self.steps} step(s) of {self.step_length:.3f} m, {len(self.phases)} phases, '
                f'{self.step_timing[0]:.1f} s per step, {self.climbing_speed:.2f} m/min')

    @property
    def climbed(self) -> float:
        """Route distance ring_a moved from the first phase to the last [m]."""
        return self.phases[-1].s_a - self.phases[0].s_a

    def rows(self) -> list[dict]:
        return [p.row() for p in self.phases]


def check_interlock(phases) -> None:
    """The gripper interlock over a phase sequence: never both open; one gripper changes at a
    time; the kinematic pose a_T_b changes only while exactly one gripper is open, and then
    the open ring is the one that moves. Raises PlanError(limit=PlanLimit.INTERLOCK)."""
    prev = None
    for ph in phases:
        where = f'step {ph.step}, phase {ph.phase}'
        if not (ph.gripper_a or ph.gripper_b):
            raise PlanError(f'{where}: interlock: both grippers open', limit=PlanLimit.INTERLOCK,
                            step=ph.step, phase=ph.phase)
        if prev is not None:
            if (prev.gripper_a != ph.gripper_a) and (prev.gripper_b != ph.gripper_b):
                raise PlanError(f'{where}: interlock: both grippers switch at once',
                                limit=PlanLimit.INTERLOCK, step=ph.step, phase=ph.phase)
            moved = (not np.allclose(ph.path, prev.path[-1], atol=1e-9)
                     or (ph.s_a != prev.s_a) or (ph.s_b != prev.s_b))
            if moved and ph.gripper_a and ph.gripper_b:
                raise PlanError(f'{where}: interlock: the robot moves while both grippers hold',
                                limit=PlanLimit.INTERLOCK, step=ph.step, phase=ph.phase)
            if moved and ((ph.s_a != prev.s_a and ph.gripper_a) or (ph.s_b != prev.s_b and ph.gripper_b)):
                raise PlanError(f'{where}: interlock: a gripping ring moves along the structure',
                                limit=PlanLimit.INTERLOCK, step=ph.step, phase=ph.phase)
        prev = ph
