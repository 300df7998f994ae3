"""The contract of the operator-side nodes (master, teleop, climbing, viewer) with the system.

Topics and services (relative names), on top of :mod:`rrps_kinematics.interfaces` and
:mod:`rrps_sim.interfaces`::

    MASTER_TARGET_POSE  geometry_msgs/PoseStamped  the operator's handle, frame MASTER_FRAME
    MASTER_STATE        sensor_msgs/JointState     the master's leg lengths (encoders)
    MASTER_POSE         geometry_msgs/PoseStamped  the master's FK, frame MASTER_FRAME
    MASTER_FEEDBACK     geometry_msgs/WrenchStamped  the slave's limits felt on the master's
                        ring_b (the virtual fixture), frame MASTER_FRAME, torque about ring_b
    TELEOP_ENABLE       std_msgs/Bool              the deadman, true at >= 10 Hz while held
    TELEOP_STATUS       diagnostic_msgs/DiagnosticStatus  values: TeleopStatus
    CLIMB_STATUS        diagnostic_msgs/DiagnosticStatus  values: ClimbStatus
    CLIMB_STEP_UP, CLIMB_STEP_DOWN, CLIMB_RESUME  std_srvs/Trigger
    OPERATOR_ROUND_TRIP std_msgs/Float64           the controlling browser's round trip [s]
    odometry_topic(ring)            geometry_msgs/PoseStamped  frame world

A status message's ``message`` is for people; nodes read the typed values
(``TeleopStatus.from_key_values(msg.values)``). Pure Python, no ROS import.
"""

from __future__ import annotations

import dataclasses
import enum

from rrps_kinematics.interfaces import StatusValues

__all__ = [
    'MASTER_TARGET_POSE', 'MASTER_STATE', 'MASTER_POSE', 'MASTER_FRAME', 'MASTER_FEEDBACK', 'TELEOP_ENABLE',
    'TELEOP_STATUS', 'CLIMB_STATUS', 'CLIMB_STEP_UP', 'CLIMB_STEP_DOWN', 'CLIMB_RESUME',
    'OPERATOR_ROUND_TRIP', 'odometry_topic', 'TeleopCode', 'DISENGAGED_CODES', 'ClimbState',
    'PauseReason', 'PhaseAction', 'TeleopStatus', 'ClimbStatus',
]

MASTER_TARGET_POSE = 'master/target_pose'
MASTER_STATE = 'master/actuators/state'
MASTER_POSE = 'master/pose'
MASTER_FRAME = 'master_ring_a'
MASTER_FEEDBACK = 'master/feedback'
TELEOP_ENABLE = 'teleop/enable'
TELEOP_STATUS = 'teleop/status'
CLIMB_STATUS = 'climb/status'
CLIMB_STEP_UP = 'climb/step_up'
CLIMB_STEP_DOWN = 'climb/step_down'
CLIMB_RESUME = 'climb/resume'
OPERATOR_ROUND_TRIP = 'operator/round_trip_time'


def odometry_topic(ring: str) -> str:
    """World pose of ``ring`` ('ring_a' or 'ring_b') chained by the climbing node."""
    if ring not in ('ring_a', 'ring_b'):
        raise ValueError(f"ring must be 'ring_a' or 'ring_b', got {ring!r}")
    return f'odometry/{ring}'


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


#: Codes under which the mapping is not engaged (no command is produced: the slave holds).
DISENGAGED_CODES = frozenset({TeleopCode.DEADMAN_RELEASED, TeleopCode.MASTER_STALE,
                              TeleopCode.WAITING_FOR_SLAVE_POSE, TeleopCode.CLIMB_EXECUTING,
                              TeleopCode.ORIENTATION_MISMATCH, TeleopCode.SLAVE_STATE_LOST,
                              TeleopCode.LINK_LATENCY, TeleopCode.DRIVER_INACTIVE})


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


class PhaseAction(enum.Enum):
    """What one phase of a climbing step does (paper section 3: the inchworm gait)."""

    START = 'start'      # the configuration the plan starts from
    RELEASE = 'release'  # open the ring's gripper
    MOVE = 'move'        # move the open ring along the structure
    GRIP = 'grip'        # close the ring's gripper


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


@dataclasses.dataclass(frozen=True)
class ClimbStatus(StatusValues):
    """climb/status values: the state, where the step is (``step``, the phase's ``action`` and
    ``ring``), the rings' route positions [m] and the reason in words (``detail``)."""

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

    @property
    def phase(self) -> str:
        """The phase's name as the plans write it ('move_b', 'grip_a', ...; '' when idle)."""
        if self.action is None:
            return ''
        return self.action.value if not self.ring else f'{self.action.value}_{self.ring[-1]}'


# --- Recording, replay and the robot for RViz / Foxglove (issue 12) --------------------------
#
#     FLIGHT_RECORDER_SAVE  std_srvs/Trigger   write the last ``buffer_seconds`` now; the answer's
#                                              ``message`` is the file's path (success true)
#     RECORDER_STATUS       /diagnostics       values: RecorderStatus (recorder_node)
#     REPLAY_STATUS         diagnostic_msgs/DiagnosticStatus  values: ReplayStatus (replay_node)
#     ROBOT_MARKERS         visualization_msgs/MarkerArray    the robot in frame ring_a and world
#     TF                    tf2_msgs/TFMessage  world -> ring_a -> ring_b and the legs' links
#
# COMMAND_TOPICS are the streams that move the robot: a replay never publishes them on their
# live names unless asked to (they go under REPLAY_PREFIX).

from rrps_kinematics.interfaces import ACTUATORS_COMMAND as _ACTUATORS_COMMAND  # noqa: E402
from rrps_kinematics.interfaces import TARGET_POSE as _TARGET_POSE  # noqa: E402

FLIGHT_RECORDER_SAVE = 'flight_recorder/save'
REPLAY_STATUS = 'replay/status'
ROBOT_MARKERS = 'robot/markers'
TF = '/tf'
REPLAY_PREFIX = 'replay'
#: Relative names of the command streams (what a replay must not feed to a live robot).
COMMAND_TOPICS = (_TARGET_POSE, _ACTUATORS_COMMAND, TELEOP_ENABLE, MASTER_TARGET_POSE)


class RecorderTrigger(enum.Enum):
    """Why the flight recorder wrote its buffer."""

    OPERATOR = 'operator'              # the flight_recorder/save service (viewer button)
    NODE_ERROR = 'node_error'          # a node's /diagnostics status at ERROR
    GRIPPER_REFUSAL = 'gripper_refusal'  # DriverStatus.gripper_refusals increased
    LINK_LOST = 'link_lost'            # teleop/status or climb/status at ERROR or STALE


@dataclasses.dataclass(frozen=True)
class RecorderStatus(StatusValues):
    """recorder_node's /diagnostics values: what is recorded and what was written."""

    recording: bool = False
    flight_recorder: bool = False
    topics: int = 0
    tapped_topics: int = 0
    bad_bundles: int = 0
    messages: int = 0
    bytes_written: int = 0
    file: str = ''
    buffered_messages: int = 0
    buffer_seconds: float = 0.0
    dumps: int = 0
    last_dump: str = ''
    last_trigger: RecorderTrigger | None = None
    dropped_topics: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class ReplayStatus(StatusValues):
    """replay/status values: where the replay is (``time`` [s] from the recording's start, of
    ``duration``), its ``rate`` (1.0 = as recorded), whether it is ``paused`` or ``finished``,
    the command topics it ``remapped`` and the topics it could not publish (``skipped``)."""

    time: float
    duration: float
    rate: float = 1.0
    paused: bool = False
    finished: bool = False
    file: str = ''
    published: int = 0
    remapped: tuple[str, ...] = ()
    skipped: tuple[str, ...] = ()


__all__ += ['FLIGHT_RECORDER_SAVE', 'REPLAY_STATUS', 'ROBOT_MARKERS', 'TF', 'REPLAY_PREFIX',
            'COMMAND_TOPICS', 'RecorderTrigger', 'RecorderStatus', 'ReplayStatus']
