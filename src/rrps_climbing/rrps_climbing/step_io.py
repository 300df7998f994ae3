"""What the climbing step machine (:mod:`.step_machine`) takes and gives: its settings, the
targets and gripper requests it commands, the plans it asks for and gets back, and the output of
each call. Pure Python; no ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from rrps_climbing.plan import Phase
from rrps_description.pose import Pose
from rrps_interfaces.climb import ClimbStatus

__all__ = ['StepConfig', 'ClimbTarget', 'GripperRequest', 'PlanRequest', 'StepPlan', 'ClimbOutput']


@dataclass(frozen=True)
class StepConfig:
    """How steps are executed (SI units); validated on construction (ValueError)."""

    period: float = 0.02                 # between ticks: the target stream's period [s]
    position_tolerance: float = 0.001    # arrival [m]
    orientation_tolerance: float = 0.01  # arrival [rad]
    settle_timeout: float = 5.0          # longest wait for an arrival or a gripper switch [s]
    settle_time: float = 0.1             # stay arrived this long before a gripper switches [s]
    state_timeout: float = 0.2           # pause when the robot's state is older [s]
    operator_timeout: float = 0.5        # pause when the operator station is silent this long [s]

    def __post_init__(self) -> None:
        for name in ('period', 'position_tolerance', 'orientation_tolerance', 'settle_timeout',
                     'state_timeout', 'operator_timeout'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{name} must be finite and > 0, got {value!r}')
        if not (math.isfinite(self.settle_time) and self.settle_time >= 0.0):
            raise ValueError(f'settle_time must be finite and >= 0, got {self.settle_time!r}')


class ClimbTarget(NamedTuple):
    """A command: ring_b's pose in ring_a and the extra-DOF angles (theta_a, theta_b) [rad]."""

    a_T_b: Pose
    ring_angles: np.ndarray


@dataclass(frozen=True, eq=False)
class GripperRequest:
    """Ask the driver to close (or open) ``ring``'s gripper; answer it with
    :meth:`ClimbStepMachine.on_gripper_answer` (matched by identity)."""

    ring: str
    close: bool


@dataclass(frozen=True)
class PlanRequest:
    """A climb of ``distance`` [m] in ``steps`` from the rings at rest (ring_a's gripper at ``s_a``
    [m], ring_b's ``separation`` [m] further, extra-DOF angle ``theta`` [rad]), the robot measured
    at ``pose`` (None: not yet) and judged arrived within ``config``'s tolerances."""

    distance: float
    steps: int
    s_a: float
    separation: float
    theta: float
    pose: Pose | None
    config: StepConfig


@dataclass(frozen=True)
class StepPlan:
    """The phases of a planned climb, its description and (duration per step [s], climbing speed
    [m/min]); or, with ``refusal``, why it has none."""

    phases: tuple[Phase, ...] = ()
    detail: str = ''
    timing: tuple[float, float] = (float('nan'), float('nan'))
    refusal: str | None = None


@dataclass
class ClimbOutput:
    """What one call of the machine asks for: a target to command, a gripper request, a status
    to report now, the rings' world poses (world_T_a, world_T_b) chained from a new pose, the
    reply to a request (accepted, message), lines to log ((logging level, text)), the plan to
    make (:func:`.step_plan.plan_step`, then :meth:`ClimbStepMachine.on_plan`) and the phases of
    a step to preview."""

    target: ClimbTarget | None = None
    gripper: GripperRequest | None = None
    status: ClimbStatus | None = None
    odometry: tuple[Pose, Pose] | None = None
    reply: tuple[bool, str] | None = None
    log: list[tuple[int, str]] = field(default_factory=list)
    plan: PlanRequest | None = None
    preview: list[Phase] | None = None
