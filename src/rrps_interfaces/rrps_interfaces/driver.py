"""The contract of the hardware driver (simulated or real) with the rest of the system: the gripper
topic and services (``GRIPPERS_STATE``: 1.0 closed, 0.0 open; ``gripper_service(ring)``: SetBool, true
= close, refused with success false; ``RESET_FAULTS``: inactive driver only) and its /diagnostics
values, :class:`DriverStatus` (docs/usage.md, 'The ROS interface'). Pure Python, no ROS import."""

from __future__ import annotations

import dataclasses
import enum
from typing import Mapping, Sequence

from rrps_description.names import RINGS
from rrps_interfaces.status import CommandAgeStatus

__all__ = ['GRIPPERS_STATE', 'RESET_FAULTS', 'gripper_service', 'gripper_states', 'supporting_ring', 'ActuatorMode',
           'SupportSource', 'DriverStatus']

GRIPPERS_STATE = 'grippers/state'
#: The driver's fault reset (the operator's, after a hardware fault; then activate again).
RESET_FAULTS = 'driver_node/reset_faults'


def gripper_service(ring: str) -> str:
    """The SetBool service that closes (true) or opens (false) ``ring``'s gripper."""
    if ring not in RINGS:
        raise ValueError(f'unknown ring {ring!r}, expected one of {RINGS}')
    return f'grippers/{ring}/set'


def gripper_states(names: Sequence[str], positions: Sequence[float]) -> dict[str, bool] | None:
    """{ring: closed} from a GRIPPERS_STATE message's names and positions; None unless both
    rings are there with finite values (a closedness of at least 0.5 counts as closed)."""
    state = dict(zip(names, positions))
    if not all(ring in state and state[ring] == state[ring] for ring in RINGS):
        return None
    return {ring: float(state[ring]) >= 0.5 for ring in RINGS}


def supporting_ring(closed: Mapping[str, bool]) -> str | None:
    """The ring whose gripper carries the robot: ring_a while it grips (both closed too, as the
    odometry takes it), ring_b while it alone grips; None when both are open."""
    if closed.get('ring_a'):
        return 'ring_a'
    return 'ring_b' if closed.get('ring_b') else None


class ActuatorMode(enum.Enum):
    """Fidelity of the simulated actuators."""

    KINEMATIC = 'kinematic'  # lag, speed and stroke limits; quasi-static forces
    DYNAMIC = 'dynamic'      # the multibody dynamics (eqs. 19-20) with a PD force loop


class SupportSource(enum.Enum):
    """Where the supporting ring's world attitude a node computes with comes from."""

    PARAMETERS = 'parameters'    # no odometry/support yet: the start attitude of the parameters
    ODOMETRY = 'odometry'        # the newest odometry/support, fresh, for the ring that supports
    HANDED_OVER = 'handed over'  # the support changed ring; the old attitude turned by the measured pose
    STALE = 'stale'              # odometry/support silent too long: the last known attitude is kept


@dataclasses.dataclass(frozen=True)
class DriverStatus(CommandAgeStatus):
    """driver_node's /diagnostics values."""

    mode: ActuatorMode = ActuatorMode.KINEMATIC
    #: the lifecycle state is active: commands move the robot, the grippers switch
    active: bool = False
    accepted: int = 0
    rejected: int = 0
    dropped: int = 0
    lengths: tuple[float, ...] = ()
    stuck_legs: tuple[int, ...] = ()
    ring_a_closed: bool = True
    ring_b_closed: bool = True
    #: gripper requests refused since the start (the interlock, a ring without a gripper)
    gripper_refusals: int = 0
    #: why the last write of ``state_file`` failed ('' when it succeeded or there is none)
    state_file_error: str = ''
    #: the hardware implementation the driver hosts (its ``hardware`` parameter)
    hardware: str = 'simulated'
    #: the hardware's latched faults, ``<actuator>:<kind>`` (kind: a FaultKind value of rrps_hardware.interface)
    faults: tuple[str, ...] = ()
    #: the ring the gravity of the efforts and dynamics is grounded on, its world attitude
    #: (x, y, z, w), where that comes from and the age [s] of the last odometry/support used
    support_ring: str = 'ring_a'
    world_q_support: tuple[float, ...] = ()
    support_source: SupportSource = SupportSource.PARAMETERS
    support_age: float | None = None
    #: odometry/support messages rejected (malformed) since the start
    support_rejected: int = 0
    #: hardware that steps its setpoints in a cycle of its own (a CANopen bus' SYNC): from a
    #: command's receipt to the first cycle that sends a setpoint of it, over the last 10 s [ms];
    #: None for hardware stepped by the driver's tick
    target_latency_p50_ms: float | None = None
    target_latency_p99_ms: float | None = None
    target_latency_max_ms: float | None = None

    @classmethod
    def grippers(cls, closed: Mapping[str, bool]) -> dict:
        """The gripper fields from {ring: closed}."""
        return {f'{ring}_closed': bool(closed[ring]) for ring in RINGS}
