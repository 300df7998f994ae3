"""The contract of the climbing node with the system: topic, action and service names, enums and
typed values (docs/usage.md, 'The ROS interface'). Pure Python, no ROS import.

``SUPPORT_POSE`` (latched) is the supporting ring's world pose that the driver's gravity and teleop's
load guards follow (which ring supports: :func:`rrps_interfaces.driver.supporting_ring`; the
contract: docs/architecture.md, 'The supporting ring's attitude')."""

from __future__ import annotations

import dataclasses
import enum
import math

from rrps_description.names import RINGS
from rrps_interfaces.status import StatusValues

__all__ = ['CLIMB_STATUS', 'CLIMB_PREVIEW', 'CLIMB_STEP', 'CLIMB_STEP_UP', 'CLIMB_STEP_DOWN', 'CLIMB_RESUME',
           'ODOMETRY', 'odometry_topic', 'SUPPORT_POSE', 'ClimbState', 'PauseReason', 'PhaseAction', 'PreviewLimit',
           'StepRefusal', 'ClimbStatus', 'ClimbPreview']

CLIMB_STATUS = 'climb/status'
CLIMB_PREVIEW = 'climb/preview'
CLIMB_STEP = 'climb/step'
CLIMB_STEP_UP = 'climb/step_up'
CLIMB_STEP_DOWN = 'climb/step_down'
CLIMB_RESUME = 'climb/resume'
SUPPORT_POSE = 'odometry/support'
ODOMETRY = 'odometry'


def odometry_topic(ring: str) -> str:
    """World pose of ``ring`` ('ring_a' or 'ring_b') chained by the climbing node."""
    if ring not in RINGS:
        raise ValueError(f"ring must be 'ring_a' or 'ring_b', got {ring!r}")
    return f'odometry/{ring}'


class ClimbState(enum.Enum):
    """The climbing node's state machine."""

    IDLE = 'idle'            # no step executing; a step may start
    EXECUTING = 'executing'  # a step owns the robot (teleoperation refuses to engage)
    PAUSED = 'paused'        # a step holds (see PauseReason) until the operator resumes it
    FAILED = 'error'         # a step failed: the robot holds; see the detail


class PauseReason(enum.Enum):
    """Why a climbing step holds. It resumes only on the operator's ``climb/resume``."""

    ROBOT_STATE_LOST = 'robot state lost'        # pose or grippers/state older than state_timeout
    OPERATOR_LINK_LOST = 'operator link lost'    # the operator station's teleop/status went silent
    DRIVER_INACTIVE = 'driver inactive'          # the driver left its active state
    CANCELLED = 'cancelled'                      # the operator cancelled the step (its action)


class PhaseAction(enum.Enum):
    """What one phase of a climbing step does (paper section 3: the inchworm gait)."""

    START = 'start'      # the configuration the plan starts from
    RELEASE = 'release'  # open the ring's gripper
    MOVE = 'move'        # move the open ring along the structure
    GRIP = 'grip'        # close the ring's gripper


class PreviewLimit(enum.Enum):
    """The load limit a step's preview breaks."""

    ACTUATOR_FORCE = 'actuator force'  # a drive is asked for more than the robot's max_force
    HOLDING = 'holding'                # a gripper's holding margin falls below its bound


class StepRefusal(enum.Enum):
    """Why a requested step did not start."""

    PLAN = 'plan'                          # the planner refused it (a pose limit on the way)
    PREVIEW_LIMIT = 'preview limit'        # its preview breaks a load limit (PreviewLimit)
    PREVIEW_FAILED = 'preview failed'      # the dynamics could not simulate it
    TELEOP_ENGAGED = 'teleop engaged'      # teleoperation engaged while it was previewed
    DRIVER_CHANGED = 'driver changed'      # the driver's state changed while it was previewed
    ROBOT_MOVED = 'robot moved'            # the pose or the grippers changed while it was previewed


@dataclasses.dataclass(frozen=True)
class ClimbStatus(StatusValues):
    """climb/status values: the state, where the step is (``step``, ``phase_index``, the phase's
    ``action`` and ``ring``), the rings' route positions [m], ``detail``; ``previewing`` (state still IDLE),
    ``refusal`` (why the last requested step did not start, else None); ``step_duration`` [s] (longest
    step) and ``climbing_speed`` [m/min] of the last plan, ``plan_duration`` [s] of the climb (NaN before)."""

    state: ClimbState
    pause_reason: PauseReason | None = None
    step: int = 0
    action: PhaseAction | None = None
    ring: str = ''
    structure: str = ''
    s_a: float = 0.0
    s_b: float = 0.0
    steps_done: int = 0
    detail: str = ''
    previewing: bool = False
    refusal: StepRefusal | None = None
    step_duration: float = math.nan
    climbing_speed: float = math.nan
    phase_index: int = 0
    phases: int = 0
    plan_duration: float = math.nan

    @property
    def phase(self) -> str:
        """The phase's name as the plans write it ('move_b', 'grip_a', ...; '' when idle)."""
        if self.action is None:
            return ''
        return self.action.value if not self.ring else f'{self.action.value}_{self.ring[-1]}'


@dataclasses.dataclass(frozen=True)
class ClimbPreview(StatusValues):
    """climb/preview values: the dynamics' preview of the last requested step. ``peak_force``
    [N] on ``peak_leg`` (1..6) against ``max_force``; the largest wrench of the structure on a
    supporting ring, ``peak_reaction_force`` [N] and ``peak_reaction_moment`` [N m]; the
    smallest holding margin ``min_margin`` (1 - utilisation; NaN: no capacity given) of
    ``min_margin_ring``; ``limit`` broken (None: accepted); ``simulated`` [s] of robot time in
    ``wall`` [s]; ``detail`` in words."""

    accepted: bool
    peak_force: float = 0.0
    peak_leg: int = 0
    max_force: float = 0.0
    peak_reaction_force: float = 0.0
    peak_reaction_moment: float = 0.0
    min_margin: float = float('nan')
    min_margin_ring: str = ''
    limit: PreviewLimit | None = None
    simulated: float = 0.0
    wall: float = 0.0
    detail: str = ''
