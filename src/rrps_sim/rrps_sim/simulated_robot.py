"""The simulated robot behind the hardware interface: actuators, ring DOFs, grippers, faults.

``mode`` ``kinematic`` (:class:`rrps_sim.kinematic_actuators.KinematicActuators`, quasi-static efforts) or
``dynamic`` (:class:`rrps_sim.actuators.DynamicActuators`, eqs. 19-20); ``write`` advances it by its
period along jerk-limited setpoints, ``read`` measures it. Gravity follows the supporting ring
(docs/architecture.md, 'The supporting ring's attitude'); the state survives the driver
(:mod:`rrps_sim.hardware_state`); :meth:`SimulatedRobot.inject_fault` latches faults for tests.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Mapping

import numpy as np

from rrps_description.loads import payload_from_parameters
from rrps_description.names import LEG_NAMES, RINGS
from rrps_description.world import Support
from rrps_hardware.commands import ring_joints
from rrps_hardware.interface import (
    OK,
    SUCCESS,
    ActuatorFault,
    ActuatorStatus,
    BusState,
    CallbackReturn,
    Command,
    FaultKind,
    HardwareConfig,
    Result,
    ReturnType,
    SystemInterface,
    SystemState,
    Transition,
)
from rrps_hardware.setpoints import JerkLimitedSetpoints
from rrps_interfaces.driver import ActuatorMode
from rrps_sim.actuators import DynamicActuators, QuasiStaticEfforts, SensorFaults
from rrps_sim.grippers import Grippers
from rrps_sim.hardware_state import HardwareState, StateFileWriter, load_state
from rrps_sim.kinematic_actuators import KinematicActuators
from rrps_sim.simulated_parameters import SIMULATED_ROBOT_PARAMETERS

__all__ = ['SimulatedRobot']

#: How long cleanup and shutdown wait for the state file to be written [s].
STATE_FILE_TIMEOUT = 2.0
#: Period of the state file's updates [s].
SAVE_PERIOD = 0.1


def _error(message: str) -> Result:
    return Result(ReturnType.ERROR, message)


class SimulatedRobot(SystemInterface):
    """The simulated hardware of one robot (see the module docstring)."""

    PARAMETERS = SIMULATED_ROBOT_PARAMETERS

    def __init__(self):
        self.actuators: KinematicActuators | DynamicActuators | None = None
        self.rings: KinematicActuators | None = None
        self.grippers: Grippers | None = None
        self.ring_joints: list[str] = []
        self.mode = ActuatorMode.KINEMATIC
        self.active = False
        self.bus = BusState.OPERATIONAL
        self.faults: dict[str, ActuatorFault] = {}
        self._commanded: Command | None = None   # the last command given to the setpoints
        self._writer: StateFileWriter | None = None
        self._saved_key: tuple | None = None
        self._saved_at = -math.inf
        self._last: SystemState | None = None

    # --- lifecycle ---

    def on_configure(self, config: HardwareConfig) -> Transition:
        values = {p.name: p.default for p in self.PARAMETERS} | dict(config.parameters)
        if self.actuators is None:  # the first configure builds the robot; later ones find it where it is
            try:
                self._build(config.geometry, values)
            except ValueError as exc:  # a bad parameter or state file
                self.actuators = None
                return Transition(CallbackReturn.FAILURE, str(exc))
        if values['state_file'] and self._writer is None:
            self._writer = StateFileWriter(values['state_file'])
        self._saved_key = None
        self._save(0.0, force=True)
        self._last = self._measure()
        return SUCCESS

    def _build(self, g, values: Mapping[str, Any]) -> None:
        for p in self.PARAMETERS:
            if values[p.name] is not None:
                p.check(values[p.name])
        payload = payload_from_parameters(values)
        if payload is not None:
            g = g.with_(payload=payload)
        support = Support.of('ring_a', values['world_q_support'])  # ValueError naming it if not unit
        self.geometry, self.mode = g, ActuatorMode(values['mode'])
        self.ring_joints = ring_joints(g)
        # a StateFileError (a ValueError) when the file cannot be trusted
        saved = load_state(values['state_file'], g, len(self.ring_joints)) if values['state_file'] else None
        initial = list(saved.lengths) if saved is not None else list(values['initial_lengths'] or ())
        lengths0 = np.array(initial if initial else g.home_lengths, dtype=float)
        if lengths0.shape != (6,) or not np.all(np.isfinite(lengths0)):
            raise ValueError(f'initial_lengths must be 6 finite lengths [m], got {initial}')
        if np.any(lengths0 < g.min_length) or np.any(lengths0 > g.max_length):
            raise ValueError(f'initial_lengths {lengths0} outside the stroke [{g.min_length}, {g.max_length}] m')
        max_speed = g.max_speed if values['limit_speed'] else math.inf
        tau = values['time_constant']
        if self.mode is ActuatorMode.DYNAMIC:
            self.actuators = DynamicActuators(g, lengths0, kp=values['kp'], kd=values['kd'], time_constant=tau,
                                              max_speed=max_speed, max_step=values['dynamics_step'],
                                              support=support)
        else:
            self.actuators = KinematicActuators(g.min_length, g.max_length, max_speed, tau, lengths0)
            self.static_efforts = QuasiStaticEfforts(g, lengths0, support=support)
        if self.ring_joints:
            dofs = [g.extra_dof[ring] for ring in RINGS if ring in g.extra_dof]
            lo, hi = np.array([d.min_angle for d in dofs]), np.array([d.max_angle for d in dofs])
            angles0 = np.clip(saved.rings if saved is not None else 0.0, lo, hi)
            self.rings = KinematicActuators(lo, hi, values['ring_rotation_speed'], tau, angles0)
        self.setpoints = JerkLimitedSetpoints(g.motion_limits.legs, lengths0) if values['jerk_limited'] else None
        self.sensors = SensorFaults(values['sensor_noise'], values['drop_probability'], values['fault_seed'])
        self._set_stuck(values['stuck_legs'] or ())
        self.grippers = Grippers(g.grippers, None if saved is None else saved.grippers, g.motion_limits.grippers)
        self._follow_grip()
        self._hold()

    @property
    def label(self) -> str:
        """The actuators' fidelity, for the driver's status."""
        return f'{self.mode.value} actuators'

    def status_values(self) -> Mapping[str, Any]:
        """The driver's status values of the simulation: the actuators' ``mode`` and the ``stuck_legs``."""
        stuck = () if self.actuators is None else tuple(int(i) + 1 for i in np.flatnonzero(self.actuators.stuck))
        return {'mode': self.mode, 'stuck_legs': stuck}

    @property
    def support(self) -> Support:
        """The gripping ring and its attitude in the world, as the efforts and dynamics use it."""
        return (self.actuators if self.mode is ActuatorMode.DYNAMIC else self.static_efforts).support

    def set_support(self, support: Support) -> Result:
        """Ground ``support`` (its attitude from the odometry) in the efforts and dynamics;
        refused for a ring that is not the one gripping (ring_a while it grips, else ring_b)."""
        if self.actuators is None:
            return _error('not configured')
        if support.ring != self.support.ring:
            return _error(f'{support.ring} does not support the robot now ({self.support.ring} does)')
        (self.actuators if self.mode is ActuatorMode.DYNAMIC else self.static_efforts).set_support(support)
        return OK

    def _follow_grip(self) -> None:
        """ring_b supports while it alone grips, ring_a otherwise (both closed: ring_a, as at start)."""
        ring = 'ring_b' if not self.grippers.closed['ring_a'] else 'ring_a'
        (self.actuators if self.mode is ActuatorMode.DYNAMIC else self.static_efforts).set_support(ring)

    def on_activate(self) -> Transition:
        if self.actuators is None:
            return Transition(CallbackReturn.FAILURE, 'not configured')
        if self.faults:
            return Transition(CallbackReturn.FAILURE, f'{self._faults_text()}: reset the faults first')
        self._hold()
        self.active = True
        return SUCCESS

    def on_deactivate(self) -> Transition:
        self.active = False
        if self.actuators is not None:
            self._hold()
        return SUCCESS

    def on_cleanup(self) -> Transition:
        self.active = False
        self._flush()
        return SUCCESS

    def on_shutdown(self) -> Transition:
        self.active = False
        if self._writer is not None:  # the last state reaches the file before the driver ends
            self._save(0.0, force=True)
            self._writer.close(timeout=STATE_FILE_TIMEOUT)
            self._writer = None
        return SUCCESS

    def on_error(self) -> Transition:
        return self.on_deactivate()

    # --- cycle ---

    def write(self, time: float, period: float, command: Command | None) -> Result:
        if self.actuators is None:
            return _error('not configured')
        accepted = OK if command is None else self._accept(command, time)
        stepped = self._step(time, period)  # the world goes on, whether the command was taken or not
        if self.grippers.update(time):   # a gripper reached the end it was commanded to
            self._follow_grip()
            self._save(0.0, force=True)
        self._save(time)
        return accepted if not accepted.ok else stepped

    def _accept(self, command: Command, time: float) -> Result:
        if self.faults:
            return _error(f'{self._faults_text()}: holding; reset the faults, then activate')
        if not self.active:
            return _error('inactive: commands are not acted on')
        lengths = np.asarray(command.lengths, dtype=float)
        if lengths.shape != (6,) or not np.all(np.isfinite(lengths)):
            return _error(f'a command is 6 finite lengths [m], got {command.lengths!r}')
        if command.rings is not None:
            rings = np.asarray(command.rings, dtype=float)
            if self.rings is None or rings.shape != self.rings.positions.shape or not np.all(np.isfinite(rings)):
                return _error(f'ring angles {command.rings!r} for ring joints {self.ring_joints}')
            self.ring_reference = rings
        self.reference = lengths
        if self.setpoints is not None and command is not self._commanded:   # a new command arrived
            self.setpoints.command(lengths, time, command.stamp)
        self._commanded = command
        return OK

    def _step(self, time: float, dt: float) -> Result:
        result = OK
        try:
            self.actuators.step(self.reference if self.setpoints is None else self.setpoints.step(time, dt), dt)
        except RuntimeError as exc:  # a singular configuration of the dynamics
            dyn = self.actuators.dynamics
            dyn.reset(dyn.position, dyn.quaternion_xyzw)
            self._hold()
            result = _error(f'dynamics failed ({exc}): reset at rest, holding')
        if self.mode is ActuatorMode.KINEMATIC:
            self.static_efforts.update(self.actuators.positions, dt)
        if self.rings is not None:
            self.rings.step(self.ring_reference, dt)
        if self.faults:
            return _error(f'{self._faults_text()}: holding; reset the faults, then activate')
        return result

    def read(self, time: float, period: float) -> SystemState:
        if self.actuators is None:
            return SystemState.no_sample()
        if self.sensors.drop():  # the actuators' sample is lost: the previous one, flagged
            last = self._last
            return replace(self._measure(noise=False), positions=last.positions, velocities=last.velocities,
                           efforts=last.efforts, ring_positions=last.ring_positions,
                           ring_velocities=last.ring_velocities, lost=True)
        self._last = self._measure()
        return self._last

    def _measure(self, *, noise: bool = True) -> SystemState:
        a = self.actuators
        efforts = a.efforts if self.mode is ActuatorMode.DYNAMIC else self.static_efforts.efforts
        # a force loop never settles exactly on its target: the dynamics never reports it reached
        reached = [self.mode is ActuatorMode.KINEMATIC and bool(v) for v in a.positions == self.reference]
        names = list(LEG_NAMES)
        rings, empty = self.rings, np.zeros(0)
        if rings is not None:
            reached += [bool(v) for v in rings.positions == self.ring_reference]
            names += self.ring_joints
        statuses = tuple(ActuatorStatus(name, enabled=self.active and not self.faults, homed=True,
                                        target_reached=ok, fault=self.faults.get(name))
                         for name, ok in zip(names, reached))
        error = self._writer.error if self._writer is not None else None
        return SystemState(
            positions=self.sensors.measure(a.positions.copy()) if noise else a.positions.copy(),
            velocities=a.velocities.copy(), efforts=np.array(efforts, dtype=float), targets=self.reference.copy(),
            grippers=dict(self.grippers.closed), actuators=statuses,
            ring_positions=empty if rings is None else rings.positions.copy(),
            ring_velocities=empty if rings is None else rings.velocities.copy(),
            ring_targets=empty if rings is None else self.ring_reference.copy(),
            bus=self.bus, persist_error='' if error is None else f'{self._writer.path} not written: {error}')

    # --- requests ---

    def hold(self) -> Result:
        if self.actuators is None:
            return _error('not configured')
        self._hold()
        return OK

    def _hold(self) -> None:
        """Track where the actuators are now (no jump towards an older target)."""
        self.reference = self.actuators.positions.copy()
        self._commanded = None
        if self.setpoints is not None:
            self.setpoints.reset(self.reference)
        if self.rings is not None:
            self.ring_reference = self.rings.positions.copy()

    def set_gripper(self, ring: str, close: bool) -> Result:
        if not self.active:
            return _error('refused: the hardware is inactive' + (f' ({self._faults_text()})' if self.faults else ''))
        before = dict(self.grippers.closed)
        accepted, message = self.grippers.set(ring, close=close)
        if self.grippers.closed != before:
            self._follow_grip()
            self._save(0.0, force=True)
        return Result(ReturnType.OK if accepted else ReturnType.ERROR, message)

    def reset_faults(self) -> Result:
        if self.bus is BusState.LOST:
            return _error('the bus is lost: no fault reset')
        cleared = self._faults_text()
        self.faults.clear()
        return Result(ReturnType.OK, f'reset {cleared}: activate to enable' if cleared else 'no fault')

    def set_parameters(self, changes: Mapping[str, Any]) -> Result:
        dynamic = {p.name: p for p in self.PARAMETERS if p.dynamic}
        unknown = sorted(set(changes) - set(dynamic))
        if unknown:
            return _error(f'not settable at run time: {", ".join(unknown)}')
        for name, value in changes.items():
            try:
                dynamic[name].check(tuple(value or ()) if dynamic[name].type is tuple else value)
            except (TypeError, ValueError) as exc:
                return _error(str(exc))
        for name, value in changes.items():
            if name == 'stuck_legs':
                self._set_stuck(value or ())
            elif name == 'sensor_noise':
                self.sensors.noise = float(value)
            elif name == 'drop_probability':
                self.sensors.drop_probability = float(value)
        return OK

    def _set_stuck(self, legs) -> None:
        stuck = np.zeros(6, dtype=bool)
        stuck[[int(i) - 1 for i in legs]] = True
        self.actuators.stuck = stuck

    # --- fault injection ---

    def inject_fault(self, kind: FaultKind, actuator: str | None = None, detail: str = '') -> None:
        """Latch a fault on ``actuator`` (a leg or a ring joint), or lose the bus (``BUS_LOST``,
        every actuator); the robot holds and is disabled until :meth:`reset_faults`."""
        names = list(LEG_NAMES) + list(self.ring_joints)
        if kind is FaultKind.BUS_LOST:
            self.bus = BusState.LOST
            targets = names
        elif actuator in names:
            targets = [actuator]
        else:
            raise ValueError(f'unknown actuator {actuator!r}; known: {", ".join(names)}')
        for name in targets:
            self.faults.setdefault(name, ActuatorFault(name, kind, detail))
        self.active = False
        self._hold()

    def restore_bus(self) -> None:
        """The bus is back; the faults it caused stay latched until :meth:`reset_faults`."""
        self.bus = BusState.OPERATIONAL

    def _faults_text(self) -> str:
        return '; '.join(str(f) for f in self.faults.values())

    # --- the state file ---

    def _save(self, time: float, *, force: bool = False) -> None:
        """Keep the physical state on disk (only when it changed by more than 1 um or a gripper
        switched) through the writer's thread, at most every SAVE_PERIOD s unless ``force``."""
        if self._writer is None:
            return
        if not force:
            if time - self._saved_at < SAVE_PERIOD:
                return
            self._saved_at = time
        lengths = tuple(round(float(v), 6) for v in self.actuators.positions)
        rings = () if self.rings is None else tuple(round(float(v), 6) for v in self.rings.positions)
        key = (lengths, rings, tuple(self.grippers.closed[r] for r in RINGS))
        if key != self._saved_key:
            self._writer.submit(HardwareState(robot=self.geometry.name, lengths=lengths, rings=rings,
                                              grippers=dict(self.grippers.closed)))
            self._saved_key = key

    def _flush(self) -> None:
        if self._writer is not None:
            self._save(0.0, force=True)
            self._writer.flush(timeout=STATE_FILE_TIMEOUT)
