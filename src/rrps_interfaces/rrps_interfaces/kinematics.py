"""The contract of the IK and FK nodes: topic names and typed status values. Pure Python, no ROS.

Names are relative (deployed under a namespace such as ``/rrps``); types, frames and QoS are in
docs/usage.md, 'The ROS interface'. Command streams: ``TARGET_POSE`` (a_T_b, frame ring_a),
``TARGET_RINGS``, ``ACTUATORS_COMMAND``; ``ROBOT_DESCRIPTION`` is latched."""

from __future__ import annotations

import dataclasses
import math

from rrps_interfaces.status import CommandAgeStatus, StatusValues

__all__ = ['TARGET_POSE', 'TARGET_RINGS', 'ACTUATORS_COMMAND', 'ACTUATORS_STATE', 'POSE', 'ROBOT_DESCRIPTION',
           'JOINT_STATES', 'IkStatus', 'FkStatus']

TARGET_POSE = 'target_pose'
TARGET_RINGS = 'target_rings'
ACTUATORS_COMMAND = 'actuators/command'
ACTUATORS_STATE = 'actuators/state'
POSE = 'pose'
#: The names robot_state_publisher reads and RViz2's RobotModel display takes by default.
ROBOT_DESCRIPTION = 'robot_description'
JOINT_STATES = 'joint_states'


@dataclasses.dataclass(frozen=True)
class IkStatus(CommandAgeStatus):
    """ik_node's /diagnostics values: accepted and rejected targets, the smallest margin of each
    limit at the last accepted target (SI units), the ages of the targets received."""

    accepted: int = 0
    rejected: int = 0
    robot: str = ''
    min_stroke_margin: float = math.nan
    min_universal_margin: float = math.nan
    min_spherical_margin: float = math.nan
    min_interference_margin: float = math.nan
    min_conditioning_margin: float = math.nan


@dataclasses.dataclass(frozen=True)
class FkStatus(StatusValues):
    """fk_node's /diagnostics values: solves, the last solve's convergence and conditioning."""

    solved: int = 0
    failed: int = 0
    converged: bool = False
    iterations: int = 0
    residual: float = math.nan
    singular: bool = False
    continuation: bool = False
    inverse_condition: float | None = None
