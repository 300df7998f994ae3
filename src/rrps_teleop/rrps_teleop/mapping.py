"""Teleoperation of an RRPS slave from a parallel master robot (§3.1), pure NumPy.

Every control step turns the latest master sample into a guarded, speed-limited slave command and
a :class:`TeleopCode` saying what limited it, in the spirit of MoveIt Servo. The modes (cartesian,
joint), the clutch, the conditions of engagement and the guards (speed, deceleration, halt,
loads) are described in docs/architecture.md, 'rrps_teleop'; a guarded step is one kernel of
:mod:`rrps_teleop.compiled_guards`, run by :mod:`rrps_teleop.guarded_step`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose, validate_pose
from rrps_description.rotations import rotation_angle_between
from rrps_description.tool import b_T_tool, ring_b_pose, tool_pose
from rrps_interfaces.teleop import TeleopCode
from rrps_kinematics.limits import pose_margins
from rrps_teleop.guarded_step import GuardedStep
from rrps_teleop.guards import GuardedCommand
from rrps_teleop.load_guard import LoadGuard, LoadMargins
from rrps_teleop.teleop_config import MODES, ROTATION_MODES, TeleopConfig, validate_scale

__all__ = [
    'MODES',
    'ROTATION_MODES',
    'TeleopConfig',
    'TeleopOutput',
    'TeleopMapping',
    'validate_scale',
]

@dataclass
class TeleopOutput:
    """One control step: the status, and the command to publish (None: publish nothing, hold)."""

    code: TeleopCode
    engaged: bool
    detail: str = ''
    command: GuardedCommand | None = None
    loads: LoadMargins | None = None

    @property
    def has_command(self) -> bool:
        return self.command is not None

    @property
    def position(self) -> np.ndarray | None:
        return None if self.command is None else self.command.position

    @property
    def quaternion_xyzw(self) -> np.ndarray | None:
        return None if self.command is None else self.command.quaternion

    @property
    def lengths(self) -> np.ndarray | None:
        return None if self.command is None else self.command.lengths

    @property
    def margins(self) -> dict[str, float]:
        """Smallest margin of each kind at the command ({} without one), the load margins too."""
        if self.command is None:
            return {}
        loads = {} if self.loads is None else {k: float(v) for k, v in zip(('force', 'holding'), self.loads[:2])
                                               if math.isfinite(v)}
        return {**self.command.margins.minimum, **loads}


class TeleopMapping:
    """The teleop state machine: feed it samples (with their receive time, s) and call :meth:`step`.

    ``backend``: 'auto' (the guards compiled when numba is available), 'numba' or 'numpy';
    ``support``: the gripping ring and its attitude, for the load guards (default ring_a upright).
    """

    def __init__(self, slave: RobotGeometry, config: TeleopConfig | None = None, *,
                 backend: str = 'auto', support=None):
        self.slave = slave
        self.loads = LoadGuard(slave, support, backend=backend)
        #: the guarded steps (:mod:`.guarded_step`), compiled or interpreted
        self.guards = GuardedStep(slave, self.loads, backend)
        self.config = self._checked(config or TeleopConfig())
        self._enable_value = False
        self._enable_time = -math.inf
        self._rearm = False  # the deadman must be released before it counts again
        self._master_pose: tuple[np.ndarray, np.ndarray] | None = None
        self._master_pose_time = -math.inf
        self._master_lengths: np.ndarray | None = None
        self._master_lengths_time = -math.inf
        self._master_late: tuple[float, str] | None = None  # (receipt, why) of the last late sample
        self._slave_pose: tuple[np.ndarray, np.ndarray] | None = None
        self._slave_pose_time: float | None = None
        self._round_trip: tuple[float, float] | None = None
        self._driver_active: bool | None = None
        #: the driver's status was heard since the slave's state was last lost (a driver that
        #: died and restarted is inactive, but its old 'active' would otherwise still count)
        self._driver_current = True
        self._climb_executing = False
        self._last_step_time: float | None = None
        self._sample_stamp: float | None = None
        self._last_step_stamp: float | None = None
        self.engaged = False
        self._command: GuardedCommand | None = None
        self._master_ref = None
        self._slave_ref: tuple[np.ndarray, np.ndarray] | None = None
        self._offsets: np.ndarray | None = None
        if self.guards.compiled:
            self.guards.warm_up(self.config)

    # --- inputs -------------------------------------------------------------------------

    def _checked(self, config: TeleopConfig) -> TeleopConfig:
        if config.control_frame == 'tool':
            b_T_tool(self.slave)  # ValueError: this robot has no tool
        return config

    def configure(self, config: TeleopConfig) -> None:
        """New parameters; disengages, so the next engage is a clutch with the new mapping."""
        self.config = self._checked(config)
        self.disengage()

    def on_enable(self, t: float, value: bool) -> None:
        """A ``teleop/enable`` sample received at ``t``; ``false`` releases at once. After
        :meth:`switch_slave` a deadman held through the switch counts only once released (a
        ``false`` sample, or none for ``enable_timeout``)."""
        if self._rearm and not (value and t - self._enable_time <= self.config.enable_timeout):
            self._rearm = False
        self._enable_value = bool(value) and not self._rearm
        self._enable_time = float(t)

    def switch_slave(self) -> None:
        """Another slave (a fleet's robot) is driven from now on: release the clutch, forget
        the old slave's pose, driver and climb state, and re-arm the deadman."""
        self.disengage()
        self._slave_pose = self._slave_pose_time = None
        self._driver_current = self._driver_active is None  # the new driver's status is awaited
        self._climb_executing = False
        self._enable_value = False
        self._rearm = True

    def on_master_pose(self, t: float, position, quaternion_xyzw, stamp: float | None = None,
                       age: float = 0.0) -> None:
        """The master's pose (its FK, frame master_ring_a) received at ``t``; ValueError if malformed.

        ``stamp``: when the master sampled it (its header), for the step's time budget. ``age``:
        how old the sample was on receipt (the receiver's clock minus its stamp) [s]; a sample
        delivered late is as fresh as when it was taken, so it cannot extend ``master_timeout``.
        """
        self._master_pose = validate_pose(position, quaternion_xyzw, what='master pose')
        self._master_pose_time = _taken_at(t, age)
        if self.config.mode == 'cartesian':
            self._sample_stamp = stamp

    def on_master_late(self, t: float, why: str) -> None:
        """A master sample received at ``t`` too late to be used (``why``): it changes nothing,
        but while the master data is stale the status says so."""
        self._master_late = (float(t), why)

    def on_master_lengths(self, t: float, lengths, stamp: float | None = None, age: float = 0.0) -> None:
        """The master's leg lengths (encoders) received at ``t``, ``age`` old (as for
        :meth:`on_master_pose`); ValueError if malformed."""
        L = np.array(lengths, dtype=float)
        if L.shape != (6,) or not (L.min() > 0.0 and L.max() < math.inf):  # NaN fails both
            raise ValueError(f'master lengths must be 6 finite positive values, got {lengths!r}')
        self._master_lengths = L
        self._master_lengths_time = _taken_at(t, age)
        if self.config.mode == 'joint':
            self._sample_stamp = stamp

    def on_slave_pose(self, position, quaternion_xyzw, t: float | None = None) -> None:
        """The slave's measured pose a_T_b (its FK), received at ``t``: the reference captured
        at engage. With ``t``, a pose older than ``state_timeout`` holds the robot."""
        self._slave_pose = validate_pose(position, quaternion_xyzw, what='slave pose')
        self._slave_pose_time = None if t is None else float(t)

    def on_round_trip(self, t: float, round_trip: float) -> None:
        """The operator's measured round trip [s] at ``t``: above ``slow_latency`` the speeds are
        scaled down, above ``hold_latency`` the robot holds (a NaN or an infinite round trip
        holds too: the link does not answer)."""
        self._round_trip = (float(t), float(round_trip))

    def set_driver_active(self, active: bool | None) -> None:
        """Whether the robot's driver is active (None: not known, not checked). Once a driver
        has reported, losing the slave's state makes its status stale: engaging waits for the
        next one."""
        self._driver_active = active
        self._driver_current = True

    def round_trip(self, t: float) -> float | None:
        """The operator's round trip [s] if one was measured in the last second."""
        if self._round_trip is None or t - self._round_trip[0] > 1.0:
            return None
        return self._round_trip[1]

    def speed_factor(self, t: float) -> float:
        """Speed scale from the operator's round trip: 1 up to slow_latency, then linearly down
        to 0.25 at hold_latency."""
        c = self.config
        rtt = self.round_trip(t)
        if rtt is None or rtt <= c.slow_latency:
            return 1.0
        if not rtt < c.hold_latency:
            return 0.25
        return 1.0 - 0.75 * (rtt - c.slow_latency) / (c.hold_latency - c.slow_latency)

    def set_climb_executing(self, executing: bool) -> None:
        """True while a climb step owns the robot: refuses to engage (disengages if engaged)."""
        self._climb_executing = bool(executing)

    def disengage(self) -> None:
        """Release the clutch: no command until the next engage."""
        self.engaged = False
        self._command = None
        self._last_step_time = self._last_step_stamp = None

    # --- the state machine -------------------------------------------------------------

    def blocking_reason(self, t: float) -> tuple[TeleopCode, str] | None:
        """Why the mapping may not be engaged at ``t`` (None: it may)."""
        c = self.config
        if self._climb_executing:
            return TeleopCode.CLIMB_EXECUTING, 'a climb step is executing'
        if self._rearm:
            return TeleopCode.DEADMAN_RELEASED, 'robot switched: release the deadman and press it again'
        if not self._enable_value:
            return TeleopCode.DEADMAN_RELEASED, 'teleop/enable is not true'
        if t - self._enable_time > c.enable_timeout:
            return TeleopCode.DEADMAN_RELEASED, f'no teleop/enable true for {t - self._enable_time:.3g} s'
        taken = self._master_pose_time if c.mode == 'cartesian' else self._master_lengths_time
        age = t - taken
        if age > c.master_timeout:
            what = 'master/pose' if c.mode == 'cartesian' else 'master/actuators/state'
            late = self._master_late
            if late is not None and late[0] > taken and t - late[0] <= c.master_timeout:
                return TeleopCode.MASTER_STALE, f'{what} arrives too late: {late[1]}'
            return TeleopCode.MASTER_STALE, f'no {what} newer than {age:.3g} s (timeout {c.master_timeout:g} s)'
        if self._slave_pose is None:
            return TeleopCode.WAITING_FOR_SLAVE_POSE, 'no slave pose yet'
        if self._slave_pose_time is not None and t - self._slave_pose_time > c.state_timeout:
            return (TeleopCode.SLAVE_STATE_LOST, f'no slave pose for {t - self._slave_pose_time:.3g} s '
                                                 f'(state_timeout {c.state_timeout:g} s)')
        if self._driver_active is False:
            return TeleopCode.DRIVER_INACTIVE, 'the driver is not active: activate it first'
        if self._driver_active is not None and not self._driver_current:
            return (TeleopCode.DRIVER_INACTIVE, "no driver status since the robot's state was lost "
                                                '(a restarted driver is inactive): waiting for it')
        rtt = self.round_trip(t)
        if rtt is not None and not rtt <= c.hold_latency:
            return (TeleopCode.LINK_LATENCY, f"the operator's round trip {rtt * 1e3:.0f} ms is above "
                                             f'{c.hold_latency * 1e3:.0f} ms')
        return None

    def check(self, t: float) -> tuple[TeleopCode, str] | None:
        """The watchdog: disengage if something blocks at ``t``; return the blocking reason."""
        blocked = self.blocking_reason(t)
        if blocked is not None:
            self.disengage()
            if blocked[0] is TeleopCode.SLAVE_STATE_LOST and self._driver_active is not None:
                self._driver_current = False
        return blocked

    def step(self, t: float) -> TeleopOutput:
        """One control step at time ``t`` [s]: engage if needed, map, guard, return the command."""
        blocked = self.check(t)
        if blocked is not None:
            return TeleopOutput(blocked[0], False, blocked[1])
        if not self.engaged:
            mismatch = self._engage()
            if mismatch is not None:
                return mismatch
        factor = self.speed_factor(t)
        dt = factor * self._time_budget(t)  # every speed limit scaled by the link's factor
        if self.config.mode == 'cartesian':
            p1, q1 = self.desired()
            self._command, code, detail = self.guards.cartesian(self._command, p1, q1, dt, self.config)
        else:
            self._command, code, detail = self.guards.joint(self._command, self.desired(), dt, self.config)
        if factor < 1.0 and code in (TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED):
            code, detail = TeleopCode.LATENCY_SLOWED, f'speeds x {factor:.2f} for the link latency'
        loads = self.loads.margins(self._command) if self.config.load_guards else None
        return TeleopOutput(code, True, detail, self._command, loads)

    def _time_budget(self, t: float) -> float:
        """dt [s] of this step for the speed limits: the time since the last step, or the time
        between the master samples if longer (samples bunched by the transport still carry the
        master's own time), at most ``max_period``."""
        dt = 0.0 if self._last_step_time is None else t - self._last_step_time
        stamp, last = self._sample_stamp, self._last_step_stamp
        if stamp is not None and last is not None:
            dt = max(dt, stamp - last)
        self._last_step_time, self._last_step_stamp = t, stamp
        return min(max(dt, 0.0), self.config.max_period)

    @property
    def enable_time(self) -> float:
        """Receive time [s] of the last ``teleop/enable`` sample (-inf before the first)."""
        return self._enable_time

    @property
    def joint_offsets(self) -> np.ndarray | None:
        """b_i of the joint-space map, calibrated at the last engage in joint mode [m]."""
        return None if self._offsets is None else self._offsets.copy()

    @property
    def command(self) -> GuardedCommand | None:
        """The last guarded command (None when disengaged)."""
        return self._command

    def desired(self) -> tuple[np.ndarray, np.ndarray] | np.ndarray:
        """The unguarded mapped target: (position, quaternion) in Cartesian mode, lengths in joint mode."""
        c = self.config
        if c.mode == 'joint':
            return np.asarray(c.joint_scale) * self._master_lengths + self._offsets
        pm, qm = self._master_pose
        pm0, qm0 = self._master_ref
        ps0, qs0 = self._slave_ref
        if c.control_frame == 'tool':  # move the tool-centre point; ring_b follows rigidly
            tcp0 = tool_pose(self.slave, Pose(ps0, qs0))
            ps0, qs0 = tcp0.position, tcp0.quaternion_xyzw
        p, q = np.empty(3), np.empty(4)
        self.guards.kernels.mapped_pose(pm, qm, pm0, qm0, ps0, qs0, c.translation_scale,
                                       c.rotation_mode == 'absolute', p, q)
        if c.control_frame == 'tool':
            a_T_b = ring_b_pose(self.slave, Pose(p, q))
            return a_T_b.position, a_T_b.quaternion_xyzw
        return p, q

    def _engage(self) -> TeleopOutput | None:
        c = self.config
        ps, qs = self._slave_pose
        if c.mode == 'cartesian' and c.rotation_mode == 'absolute':
            error = rotation_angle_between(qs, self._master_pose[1])
            if error > c.align_tolerance:
                return TeleopOutput(TeleopCode.ORIENTATION_MISMATCH, False,
                                    f'master and slave orientations differ by {error:.3f} rad '
                                    f'> align_tolerance {c.align_tolerance:g} rad: align the master')
        m = pose_margins(self.slave, ps, qs)
        self._command = GuardedCommand.at(ps, qs, m.lengths, m, self.slave.min_conditioning)
        self._slave_ref = (ps.copy(), qs.copy())
        if c.mode == 'cartesian':
            self._master_ref = (self._master_pose[0].copy(), self._master_pose[1].copy())
        else:
            self._offsets = m.lengths - np.asarray(c.joint_scale) * self._master_lengths
        self.engaged = True
        self._last_step_time = self._last_step_stamp = None
        return None


def _taken_at(t: float, age: float) -> float:
    """When a sample received at ``t`` was taken, ``age`` earlier (a negative or NaN age, from
    a clock ahead of ours, counts as none)."""
    return float(t) - (float(age) if age > 0.0 else 0.0)
