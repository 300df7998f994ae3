"""The contract of the master robot and the teleoperation node with the system: topic names and
typed values (docs/usage.md, 'The ROS interface'). Pure Python, no ROS import.

``MASTER_FEEDBACK`` is the slave's limits felt on the master's ring_b (the virtual fixture; frame
``MASTER_FRAME``, torque about ring_b); ``TELEOP_ENABLE`` is the deadman, true at >= 10 Hz while held."""

from __future__ import annotations

import dataclasses
import enum

from rrps_interfaces.driver import SupportSource
from rrps_interfaces.status import StatusValues

__all__ = ['MASTER_TARGET_POSE', 'MASTER_STATE', 'MASTER_POSE', 'MASTER_FRAME', 'MASTER_FEEDBACK',
           'TELEOP_ENABLE', 'TELEOP_STATUS', 'OPERATOR_ROUND_TRIP', 'TeleopCode', 'DISENGAGED_CODES',
           'TeleopStatus', 'ViewerStatus']

MASTER_TARGET_POSE = 'master/target_pose'
MASTER_STATE = 'master/actuators/state'
MASTER_POSE = 'master/pose'
MASTER_FRAME = 'master_ring_a'
MASTER_FEEDBACK = 'master/feedback'
TELEOP_ENABLE = 'teleop/enable'
TELEOP_STATUS = 'teleop/status'
OPERATOR_ROUND_TRIP = 'operator/round_trip_time'


class TeleopCode(enum.IntEnum):
    """What limited the last teleoperation step.

    -1 .. 6 are numbered as MoveIt Servo's ``moveit_servo::StatusCode`` (moveit_servo/utils/
    datatypes.hpp, MoveIt 2.x) where the meaning is the same (3, decelerating while leaving a
    singularity, is not used: leaving is at full speed); rrps' own codes start at 100.
    """

    INVALID = -1                      # bad input or a failed FK of the candidate lengths
    NO_WARNING = 0                    # engaged, following the master unhindered
    DECELERATE_FOR_APPROACHING_SINGULARITY = 1
    HALT_FOR_SINGULARITY = 2
    DECELERATE_FOR_COLLISION = 4      # approaching leg-leg interference (paper Figure 8c)
    HALT_FOR_COLLISION = 5
    JOINT_BOUND = 6                   # stroke or universal/spherical joint-angle limit
    SPEED_LIMITED = 100               # the master moves faster than the slave may
    DEADMAN_RELEASED = 101            # teleop/enable not true, or older than enable_timeout
    MASTER_STALE = 102                # no master data for master_timeout
    WAITING_FOR_SLAVE_POSE = 103      # nothing to engage from yet
    CLIMB_EXECUTING = 104             # a climb step owns the robot
    ORIENTATION_MISMATCH = 105        # absolute rotation mode: align the master first
    SLAVE_STATE_LOST = 106            # no slave pose (its actuators/state) for state_timeout
    LINK_LATENCY = 107                # the operator's round trip is above hold_latency
    DRIVER_INACTIVE = 108             # the robot's driver is not active (activate it first)
    LATENCY_SLOWED = 109              # engaged, slowed down: round trip above slow_latency
    DECELERATE_FOR_FORCE = 110        # approaching an actuator's force limit (max_force)
    HALT_FOR_FORCE = 111              # at or beyond it: motion towards it holds
    DECELERATE_FOR_HOLDING = 112      # the supporting gripper approaching its holding capacity
    HALT_FOR_HOLDING = 113            # at a holding margin of zero: motion towards it holds


#: Codes under which the mapping is not engaged (no command is produced: the slave holds).
DISENGAGED_CODES = frozenset({TeleopCode.DEADMAN_RELEASED, TeleopCode.MASTER_STALE,
                              TeleopCode.WAITING_FOR_SLAVE_POSE, TeleopCode.CLIMB_EXECUTING,
                              TeleopCode.ORIENTATION_MISMATCH, TeleopCode.SLAVE_STATE_LOST,
                              TeleopCode.LINK_LATENCY, TeleopCode.DRIVER_INACTIVE})


@dataclasses.dataclass(frozen=True)
class TeleopStatus(StatusValues):
    """teleop/status values: the code, whether the mapping is engaged, the mapping parameters,
    the reason in words (``detail``) and the smallest margin of each limit at the command."""

    code: TeleopCode
    engaged: bool
    mode: str = 'cartesian'
    scale: float = 1.0
    rotation_mode: str = 'relative'
    joint_scale: tuple[float, ...] = ()
    detail: str = ''
    round_trip_time: float | None = None
    speed_factor: float = 1.0
    feedback_force: float = 0.0          # |force| of master/feedback [N]
    feedback_limit: str = ''             # the limit that pushes hardest ('' when none)
    margin_stroke: float | None = None
    margin_universal: float | None = None
    margin_spherical: float | None = None
    margin_interference: float | None = None
    margin_conditioning: float | None = None
    margin_force: float | None = None    # 1 - max |f_i| / max_force at the command (load guards)
    margin_holding: float | None = None  # 1 - the supporting gripper's utilisation there
    robot: str = ''                      # the namespace of the driven robot
    slave_age_ms: float | None = None    # now minus the newest slave pose's stamp (synchronised clocks)
    support_ring: str = ''               # the ring the load guards take as carrying the robot
    support_source: SupportSource | None = None  # where its world attitude comes from


@dataclasses.dataclass(frozen=True)
class ViewerStatus(StatusValues):
    """viewer_node's /diagnostics values: how many robots it lists and how many of them it heard
    in the last 2 s, the one it draws (its namespace), the frames it drew and the drawn robot's
    pose samples it received per second over the last second, that pose's age [ms] and the
    browsers connected."""

    robots: int = 1
    heard: int = 0
    drawn: str = ''
    draw_rate: float = 0.0
    pose_rate: float = 0.0
    pose_age_ms: float | None = None
    clients: int = 0
