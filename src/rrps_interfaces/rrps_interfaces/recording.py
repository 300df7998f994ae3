"""The contract of recording, replay and the robot for RViz2 / Foxglove: topic and service names
(docs/recording.md). Pure Python, no ROS import.

``COMMAND_TOPICS`` are the streams that move the robot: a replay never publishes them on their live
names unless asked to (they go under ``REPLAY_PREFIX``)."""

from __future__ import annotations

import dataclasses
import enum

from rrps_interfaces.kinematics import ACTUATORS_COMMAND, TARGET_POSE
from rrps_interfaces.status import StatusValues
from rrps_interfaces.teleop import MASTER_TARGET_POSE, TELEOP_ENABLE

__all__ = ['RECORDING_TAP', 'FLIGHT_RECORDER_SAVE', 'REPLAY_STATUS', 'ROBOT_MARKERS', 'TF', 'TF_STATIC',
           'CLOCK', 'REPLAY_PREFIX',
           'COMMAND_TOPICS', 'RecorderTrigger', 'RecorderStatus', 'ReplayStatus']

#: A node's private topic of recording bundles: ``<namespace>/<node>/recording_tap``.
RECORDING_TAP = 'recording_tap'
FLIGHT_RECORDER_SAVE = 'flight_recorder/save'
REPLAY_STATUS = 'replay/status'
ROBOT_MARKERS = 'robot/markers'
TF = '/tf'
TF_STATIC = '/tf_static'
CLOCK = '/clock'
REPLAY_PREFIX = 'replay'
#: Relative names of the command streams (what a replay must not feed to a live robot).
COMMAND_TOPICS = (TARGET_POSE, ACTUATORS_COMMAND, TELEOP_ENABLE, MASTER_TARGET_POSE)


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
