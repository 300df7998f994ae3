"""The hardware interface of the driver, modelled on ros2_control's ``hardware_interface::SystemInterface``.

Lifecycle verbs return a :class:`Transition`, requests a :class:`Result`, ``read`` a
:class:`SystemState` with per-actuator :class:`ActuatorFault` and the :class:`BusState`: no
exception crosses the interface. SI units (m, m/s, N, rad). Fits a CANopen CiA 402 backend: a
faulted drive stays disabled (``on_activate`` refused) until ``reset_faults``, which needs the bus.
"""

from __future__ import annotations

import abc
import enum
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.world import Support
from rrps_runtime.parameter_schema import Parameter
from rrps_runtime.scheduling import Request

__all__ = ['CallbackReturn', 'ReturnType', 'Transition', 'Result', 'SUCCESS', 'OK', 'FaultKind', 'ActuatorFault',
           'BusState', 'ActuatorStatus', 'Command', 'SystemState', 'HardwareConfig', 'SystemInterface']


class CallbackReturn(enum.Enum):
    """Outcome of a lifecycle verb (rclcpp_lifecycle's CallbackReturn)."""

    SUCCESS = 'success'
    FAILURE = 'failure'  # refused: the system stays in its state
    ERROR = 'error'      # failed: the caller goes through on_error


class ReturnType(enum.Enum):
    """Outcome of read, write and the requests (hardware_interface::return_type)."""

    OK = 'ok'
    ERROR = 'error'


@dataclass(frozen=True)
class Transition:
    """A lifecycle verb's outcome and, unless SUCCESS, the reason (on SUCCESS, what the hardware
    had to leave out, for the operator: '' when nothing)."""

    code: CallbackReturn
    reason: str = ''

    @property
    def ok(self) -> bool:
        return self.code is CallbackReturn.SUCCESS


@dataclass(frozen=True)
class Result:
    """A write's or a request's outcome, with a message for people (why, when refused)."""

    code: ReturnType
    message: str = ''

    @property
    def ok(self) -> bool:
        return self.code is ReturnType.OK


#: A lifecycle verb that succeeded, a write or request that went through.
SUCCESS = Transition(CallbackReturn.SUCCESS)
OK = Result(ReturnType.OK)


class FaultKind(enum.Enum):
    """What went wrong with one actuator."""

    FOLLOWING_ERROR = 'following_error'  # too far from its target
    DRIVE_FAULT = 'drive_fault'          # the drive's fault bit (over-current, temperature, ...)
    EMERGENCY = 'emergency'              # the drive reported an error (a CANopen EMCY: its code in the detail)
    LOST_HEARTBEAT = 'lost_heartbeat'    # the drive stopped answering
    REBOOTED = 'rebooted'                # the drive restarted (it lost its homing)
    BUS_LOST = 'bus_lost'                # the bus carrying it went down
    GRIPPER_SENSOR = 'gripper_sensor'    # a gripper's clamp sensor disagrees with its command
    HOMING = 'homing'                    # the homing failed, or ended where the actuator cannot be


@dataclass(frozen=True)
class ActuatorFault:
    """A latched fault of one actuator (a leg, a ring's extra DOF, or a ring's gripper)."""

    actuator: str
    kind: FaultKind
    detail: str = ''

    def __str__(self) -> str:
        return f'{self.actuator}: {self.kind.value}' + (f' ({self.detail})' if self.detail else '')


class BusState(enum.Enum):
    """The link to the drives."""

    OPERATIONAL = 'operational'
    LOST = 'lost'


@dataclass(frozen=True)
class ActuatorStatus:
    """One actuator as its drive reports it: ``enabled`` (following its target), ``homed`` (its
    position is absolute), ``target_reached`` (at its target), and its latched fault, if any."""

    name: str
    enabled: bool
    homed: bool
    target_reached: bool
    fault: ActuatorFault | None = None


@dataclass(frozen=True)
class Command:
    """Commanded leg lengths (6,) [m] and, for robots with them, the rings' extra-DOF angles
    [rad] in the order of the state's ring joints (None: keep their targets); ``stamp`` [s]: the
    time of the command's sample in its stream (its message's stamp; None: unstamped)."""

    lengths: np.ndarray
    rings: np.ndarray | None = None
    stamp: float | None = None


@dataclass(frozen=True)
class SystemState:
    """One sample of the hardware, SI units: legs (6,), the rings' extra DOF (k,) [rad], the grippers
    as measured, actuator and gripper faults. ``lost``: this cycle's sample did not arrive (the
    previous one's values); ``persist_error``: why the state could not be kept across driver
    restarts ('' if it could); ``rest_speed``: below it a velocity cannot tell motion from rest."""

    positions: np.ndarray
    velocities: np.ndarray
    efforts: np.ndarray
    targets: np.ndarray
    grippers: Mapping[str, bool]
    actuators: tuple[ActuatorStatus, ...]
    ring_positions: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ring_velocities: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ring_targets: np.ndarray = field(default_factory=lambda: np.zeros(0))
    bus: BusState = BusState.OPERATIONAL
    lost: bool = False
    persist_error: str = ''
    gripper_faults: tuple[ActuatorFault, ...] = ()
    rest_speed: float = 1e-9

    @classmethod
    def no_sample(cls) -> SystemState:
        """What an unconfigured system reads: no actuators, lost."""
        empty = np.zeros(0)
        return cls(empty, empty, empty, empty, {}, (), lost=True)

    @property
    def faults(self) -> tuple[ActuatorFault, ...]:
        """The latched faults, in actuator order, then the grippers'."""
        return tuple(a.fault for a in self.actuators if a.fault is not None) + self.gripper_faults

    def at_rest(self, speed: float | None = None) -> bool:
        """Every actuator at its target and none faster than ``speed`` [m/s, rad/s] (by default
        :attr:`rest_speed`)."""
        speed = self.rest_speed if speed is None else speed
        return (all(a.target_reached for a in self.actuators) and not np.any(np.abs(self.velocities) > speed)
                and not np.any(np.abs(self.ring_velocities) > speed))


@dataclass(frozen=True)
class HardwareConfig:
    """What ``on_configure`` gets: the robot, the values {name: value} of the implementation's
    :attr:`SystemInterface.PARAMETERS` as the host declared them, and the scheduling the host's
    command path asked for (its ``rt_priority``, ``cpu_affinity``; None: none), which threads the
    implementation starts for its own cycles claim above it (as ros2_control's hardware threads)."""

    geometry: RobotGeometry
    parameters: Mapping[str, Any] = field(default_factory=dict)
    scheduling: Request | None = None


class SystemInterface(abc.ABC):
    """The hardware of one robot: six leg actuators, the rings' extra DOF and two grippers.

    Lifecycle as ros2_control's (inactive: sensors report, nothing moves; active: commands move,
    grippers switch); each cycle ``write`` then ``read``. A fault disables the system: it holds,
    and ``on_activate`` is refused until ``reset_faults``.
    """

    #: The parameters this implementation owns and reads from :attr:`HardwareConfig.parameters`:
    #: the driver declares them once its ``hardware`` parameter names this implementation, and
    #: passes changes of the ``dynamic`` ones to :meth:`set_parameters` while it runs.
    PARAMETERS: tuple[Parameter, ...] = ()
    #: The implementation steps its setpoints in a real-time cycle of its own (a bus' SYNC):
    #: the host writes each command as it arrives, and ``write`` hands it over to that cycle.
    OWN_CYCLE: bool = False

    @abc.abstractmethod
    def on_configure(self, config: HardwareConfig) -> Transition:
        """Connect to the hardware (or build it) and read its state; nothing moves."""

    @abc.abstractmethod
    def on_activate(self) -> Transition:
        """Enable the actuators, holding where they are; refused while a fault is latched."""

    @abc.abstractmethod
    def on_deactivate(self) -> Transition:
        """Stop following commands and hold where the actuators are."""

    @abc.abstractmethod
    def on_cleanup(self) -> Transition:
        """Release what ``on_configure`` took, keeping the state it must keep."""

    @abc.abstractmethod
    def on_shutdown(self) -> Transition:
        """Stop for good (the driver ends); safe to call in any state, and more than once."""

    @abc.abstractmethod
    def on_error(self) -> Transition:
        """Bring the hardware to a safe stop after a failed verb or write."""

    @abc.abstractmethod
    def write(self, time: float, period: float, command: Command | None) -> Result:
        """Send this cycle's command (None: keep the current targets); ``time`` [s] is the
        host's monotonic clock, ``period`` [s] the time since the previous cycle. ERROR while
        faulted, inactive (a command) or when the hardware had to stop (the reason)."""

    @abc.abstractmethod
    def read(self, time: float, period: float) -> SystemState:
        """This cycle's sample of the hardware."""

    @abc.abstractmethod
    def hold(self) -> Result:
        """Stop where the actuators are now and keep that as their targets."""

    @abc.abstractmethod
    def set_gripper(self, ring: str, close: bool) -> Result:
        """Close or open ``ring``'s gripper; refused (ERROR, the reason) unless active, for a ring
        without a gripper, and when opening it would leave no ring gripping."""

    @abc.abstractmethod
    def reset_faults(self) -> Result:
        """Clear the latched faults (the CiA 402 fault reset); the system stays inactive.
        Refused while the bus is lost."""

    @property
    def label(self) -> str:
        """What the driver's status calls this hardware ('': by its registered name, this default)."""
        return ''

    def status_values(self) -> Mapping[str, Any]:
        """This hardware's own values of the driver's status (fields of
        :class:`rrps_interfaces.driver.DriverStatus`); none by default."""
        return {}

    @property
    def support(self) -> Support | None:
        """The supporting ring and its world attitude the hardware computes gravity with (a
        simulation); None for hardware that lives in the real world's gravity (this default)."""
        return None

    def set_support(self, support: Support) -> Result:
        """Ground ``support`` (the ring that grips, its attitude from the odometry) in the
        simulated world; this default has nothing to do (real gravity needs no attitude)."""
        return OK

    def set_parameters(self, changes: Mapping[str, Any]) -> Result:
        """Apply run-time changes of dynamic :attr:`PARAMETERS`; this default refuses them all."""
        if not changes:
            return OK
        return Result(ReturnType.ERROR, f'{type(self).__name__} has no run-time parameter '
                                        f'{", ".join(sorted(changes))}')
