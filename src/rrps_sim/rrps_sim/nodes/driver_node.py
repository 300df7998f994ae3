"""driver_node: the simulated hardware. actuators/command -> actuators/state, plus the grippers.

A managed (lifecycle) node: it configures itself at start-up and then sits **inactive**:
``actuators/state`` and ``grippers/state`` are published (the hardware's sensors), but no
command moves the robot and the grippers do not switch until an explicit ``activate`` through
the standard ``driver_node/change_state`` service (the operator's button in the viewer). The
parameter ``auto_activate`` activates at start (the demo's first start only). A restarted
driver is inactive again. With ``state_file`` the robot's physical state (leg lengths, ring
angles, grippers) is kept on disk and a restarted driver resumes it
(:mod:`rrps_sim.hardware_state`): it never teleports home nor reports closed a gripper that was
open. The file is written by a thread of its own, never by the loop (a file system under load
blocked a write for a second); a failed write is reported (WARN, ``state_file_error``).
Deactivating holds the robot where it is.

Modes (parameter ``mode``): ``kinematic`` (:class:`rrps_sim.actuators.KinematicActuators`: lag,
speed and stroke limits; effort = the quasi-static holding forces of the pose, refreshed at
5 Hz) and ``dynamic`` (:class:`rrps_sim.actuators.DynamicActuators`: the multibody dynamics of
eqs. 19-20 with a PD force loop per leg, effort = force [N]). The state is published at
``rate`` Hz while the robot moves or is commanded, at ``idle_rate`` (50 Hz) once it has rested
for 0.5 s (kinematic mode), and at once on each accepted command with ``publish_on_command``.

A command is not acted on (the actuators keep tracking the last accepted one; /diagnostics and
the log say why) when it is malformed (names, sizes, NaN), unstamped, outside the stroke, or stamped more
than ``timeout`` s ago. With ``hold_when_silent`` the actuators also stop where they are when no
command arrived for ``timeout`` s. Grippers: ``grippers/state`` and the SetBool services
``grippers/ring_a/set`` / ``grippers/ring_b/set`` (true = close), never both open.
Faults for tests, settable at run time: ``stuck_legs``, ``sensor_noise``, ``drop_probability``.

    driver_node --ros-args -r __ns:=/rrps -p robot:=pole_climber
"""

from __future__ import annotations

import math
import time

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.lifecycle import LifecycleNode, State, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from rrps_description.names import LEG_NAMES, RINGS, ring_joint
from rrps_interfaces.driver import GRIPPERS_STATE, ActuatorMode, DriverStatus, gripper_service
from rrps_interfaces.kinematics import ACTUATORS_COMMAND, ACTUATORS_STATE
from rrps_kinematics.forward import forward_kinematics
from rrps_runtime.diagnostics import ERROR, OK, STALE, WARN, Diagnostics
from rrps_runtime.freshness import CommandAges, CommandFreshness, RejectedCommand
from rrps_runtime.messages import joint_state_msg, lengths_from_joint_state, stamp_to_seconds
from rrps_runtime.parameters import declare_parameter, declare_robot_parameter
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_sim.actuators import DynamicActuators, KinematicActuators, QuasiStaticEfforts, SensorFaults
from rrps_sim.grippers import Grippers
from rrps_sim.hardware_state import HardwareState, StateFileWriter, load_state

__all__ = ['DriverNode', 'main']

MODES = tuple(m.value for m in ActuatorMode)
#: How long a lifecycle transition or the shutdown waits for the state file to be written [s].
STATE_FILE_TIMEOUT = 2.0


def _declare_array(node: Node, name: str, kind, description: str) -> list:
    """An array parameter that may be left unset (returns [])."""
    descriptor = ParameterDescriptor(description=description, type={
        Parameter.Type.DOUBLE_ARRAY: ParameterType.PARAMETER_DOUBLE_ARRAY,
        Parameter.Type.INTEGER_ARRAY: ParameterType.PARAMETER_INTEGER_ARRAY}[kind])
    value = node.declare_parameter(name, kind, descriptor).value
    return list(value) if value is not None else []


class DriverNode(LifecycleNode):
    """Simulated actuators and grippers of one robot (a lifecycle node; see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('driver_node', **kwargs)
        g = self.geometry = declare_robot_parameter(self)
        self.mode = declare_parameter(self, 'mode', 'kinematic', 'actuator fidelity: kinematic | dynamic',
                                      read_only=True, additional_constraints='kinematic or dynamic')
        if self.mode not in MODES:
            raise ValueError(f'mode must be one of {MODES}, got {self.mode!r}')
        self.mode = ActuatorMode(self.mode)
        self.rate = declare_parameter(self, 'rate', 500.0, 'actuators/state publication rate [Hz]',
                                      min_value=1.0, max_value=5000.0, read_only=True)
        self.idle_rate = declare_parameter(
            self, 'idle_rate', 50.0, 'actuators/state rate while the robot rests (no motion, no '
            'command for 0.5 s; kinematic mode) [Hz]; equal to rate: always rate',
            min_value=1.0, max_value=5000.0, read_only=True)
        self.timeout = declare_parameter(self, 'timeout', 0.1,
                                         'a command stamped longer ago than this [s] is not acted on',
                                         min_value=1e-3, max_value=60.0)
        time_constant = declare_parameter(self, 'time_constant', 0.02,
                                          'first-order lag of the actuators [s]; 0 = none',
                                          min_value=0.0, max_value=10.0, read_only=True)
        limit_speed = declare_parameter(self, 'limit_speed', True,
                                        "limit the actuators to the robot's max_speed", read_only=True)
        self.publish_on_command = declare_parameter(
            self, 'publish_on_command', False,
            'also publish actuators/state at once when a command is accepted', read_only=True)
        self.hold_when_silent = declare_parameter(
            self, 'hold_when_silent', False,
            'stop the actuators where they are when no command arrived for timeout s', read_only=True)
        kp = declare_parameter(self, 'kp', 1.0e5, 'dynamic mode: PD stiffness per leg [N/m]',
                               min_value=0.0, max_value=1e8, read_only=True)
        kd = declare_parameter(self, 'kd', 1.0e3, 'dynamic mode: PD damping per leg [N s/m]',
                               min_value=0.0, max_value=1e6, read_only=True)
        dynamics_step = declare_parameter(self, 'dynamics_step', 1e-3,
                                          'dynamic mode: largest integration step [s]',
                                          min_value=1e-5, max_value=0.01, read_only=True)
        ring_speed = declare_parameter(self, 'ring_rotation_speed', 1.0,
                                       'speed of the extra ring DOF [rad/s] (robots that have one)',
                                       min_value=1e-3, max_value=100.0, read_only=True)
        initial = _declare_array(self, 'initial_lengths', Parameter.Type.DOUBLE_ARRAY,
                                 'initial leg lengths [m] (6); unset = the home pose')
        self._stuck = _declare_array(self, 'stuck_legs', Parameter.Type.INTEGER_ARRAY,
                                     'fault: legs (1..6) that ignore commands and keep their length')
        self._noise = declare_parameter(self, 'sensor_noise', 0.0,
                                        'fault: std of Gaussian noise on the published lengths [m]',
                                        min_value=0.0, max_value=0.1)
        self._drop = declare_parameter(self, 'drop_probability', 0.0,
                                       'fault: probability of dropping an actuators/state message',
                                       min_value=0.0, max_value=1.0)
        seed = declare_parameter(self, 'fault_seed', 0, 'seed of the fault injection',
                                 min_value=0, max_value=2**31 - 1, read_only=True)
        self.state_file = declare_parameter(
            self, 'state_file', '', "file that keeps the robot's physical state across driver "
            'restarts (lengths, ring angles, grippers); empty: none', read_only=True)
        auto_activate = declare_parameter(self, 'auto_activate', False,
                                          'activate at start (otherwise: change_state activate)',
                                          read_only=True)
        ring_names = [ring_joint(ring) for ring in RINGS if ring in g.extra_dof]
        saved = load_state(self.state_file, g, len(ring_names)) if self.state_file else None
        if saved is not None:
            initial = list(saved.lengths)

        lengths0 = np.array(initial if initial else g.home_lengths, dtype=float)
        if lengths0.shape != (6,) or not np.all(np.isfinite(lengths0)):
            raise ValueError(f'initial_lengths must be 6 finite lengths [m], got {initial}')
        if np.any(lengths0 < g.min_length) or np.any(lengths0 > g.max_length):
            raise ValueError(f'initial_lengths {lengths0} outside the stroke '
                             f'[{g.min_length}, {g.max_length}] m')
        max_speed = g.max_speed if limit_speed else math.inf
        if self.mode is ActuatorMode.DYNAMIC:
            if not forward_kinematics(g, lengths0).converged:
                raise ValueError(f'initial_lengths {lengths0} do not assemble near the home pose')
            self.actuators = DynamicActuators(g, lengths0, kp=kp, kd=kd, time_constant=time_constant,
                                              max_speed=max_speed, max_step=dynamics_step)
        else:
            self.actuators = KinematicActuators(g.min_length, g.max_length, max_speed, time_constant,
                                                lengths0)
            self.static_efforts = QuasiStaticEfforts(g, lengths0)
        self.ring_names = ring_names
        self.rings = None
        if self.ring_names:
            dofs = [g.extra_dof[name.removesuffix('_rotation')] for name in self.ring_names]
            lo = np.array([d.min_angle for d in dofs])
            hi = np.array([d.max_angle for d in dofs])
            angles0 = np.clip(saved.rings if saved is not None else 0.0, lo, hi)
            self.rings = KinematicActuators(lo, hi, ring_speed, time_constant, angles0)
        self.names = list(LEG_NAMES) + self.ring_names
        self.reference = lengths0.copy()
        self.ring_reference = None if self.rings is None else self.rings.positions.copy()
        self.faults = SensorFaults(self._noise, self._drop, seed)
        self._apply_stuck(self._stuck)
        self.grippers = Grippers(g.grippers, None if saved is None else saved.grippers)
        self.active = False
        self._saved: tuple | None = None

        self.accepted = 0
        self.rejected = 0
        self.dropped = 0
        self.gripper_refusals = 0
        self.ages = CommandAges()
        self.freshness = CommandFreshness(self.timeout)
        self._last_command_time: float | None = None
        self._last_step = time.monotonic()
        self._max_dt = 5.0 / self.rate
        resumed = f'resumed from {self.state_file}' if saved is not None else 'initial lengths'
        self._status = (WARN, f'inactive ({resumed}): activate through {self.get_name()}/change_state')
        self._tap = RecordingTap(self)
        self._state_pub = self._tap.create_publisher(JointState, ACTUATORS_STATE, STATE_QOS)
        self._grippers_pub = self._tap.create_publisher(JointState, GRIPPERS_STATE, STATE_QOS)
        self.create_subscription(JointState, ACTUATORS_COMMAND, self._on_command, COMMAND_QOS)
        for ring in RINGS:
            self.create_service(SetBool, gripper_service(ring),
                                lambda request, response, ring=ring:
                                self._on_gripper(ring, request, response))
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._diag = Diagnostics(self, f'{self.mode.value} actuators', hardware_id=g.name)
        self._tick_timer = self.create_timer(1.0 / self.rate, self._on_tick)
        self._resting = False
        self.create_timer(0.05, self._publish_grippers)
        self.create_timer(0.5, self._report)
        # the file is written by a thread of its own: a file system that blocks never holds the loop
        self._state_writer = StateFileWriter(self.state_file) if self.state_file else None
        if self._state_writer is not None:
            self.create_timer(0.1, self._save_state)
            self._save_state()
        self.trigger_configure()
        if auto_activate:
            self.trigger_activate()

    # --- lifecycle ---

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._hold()
        self.active = True
        self._set_status(OK, f'{self.mode.value} actuators active, holding: waiting for actuators/command')
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self.active = False
        self._hold()
        self._set_status(WARN, f'inactive: holding; activate through {self.get_name()}/change_state')
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._save_state(wait=True)
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        self.active = False
        self._save_state(wait=True)
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        if self._state_writer is not None:  # the last state reaches the file before the process ends
            self._save_state()
            self._state_writer.close(timeout=STATE_FILE_TIMEOUT)
            self._state_writer = None
        super().destroy_node()

    def _hold(self) -> None:
        """Track where the actuators are now (no jump towards an older reference)."""
        self.reference = self.actuators.positions.copy()
        if self.rings is not None:
            self.ring_reference = self.rings.positions.copy()
        self._last_command_time = None

    def _save_state(self, *, wait: bool = False) -> None:
        """Keep the physical state on disk (only when it changed by more than 1 um or a gripper
        switched), through the writer's thread; ``wait`` (a lifecycle transition, not the loop)
        waits up to STATE_FILE_TIMEOUT for it to be written."""
        if self._state_writer is None:
            return
        lengths = tuple(round(float(v), 6) for v in self.actuators.positions)
        rings = () if self.rings is None else tuple(round(float(v), 6) for v in self.rings.positions)
        key = (lengths, rings, tuple(self.grippers.closed[r] for r in RINGS))
        if key != self._saved:
            self._state_writer.submit(HardwareState(robot=self.geometry.name, lengths=lengths,
                                                    rings=rings, grippers=dict(self.grippers.closed)))
            self._saved = key
        if wait:
            self._state_writer.flush(timeout=STATE_FILE_TIMEOUT)

    # --- faults ---

    def _apply_stuck(self, legs) -> None:
        stuck = np.zeros(6, dtype=bool)
        stuck[[int(i) - 1 for i in legs]] = True
        self.actuators.stuck = stuck

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        for p in parameters:
            if p.name == 'stuck_legs':
                legs = list(p.value or [])
                if any(not 1 <= int(i) <= 6 for i in legs):
                    return SetParametersResult(successful=False,
                                               reason=f'stuck_legs must be in 1..6, got {legs}')
        for p in parameters:
            if p.name == 'stuck_legs':
                self._apply_stuck(list(p.value or []))
            elif p.name == 'sensor_noise':
                self.faults.noise = float(p.value)
            elif p.name == 'drop_probability':
                self.faults.drop_probability = float(p.value)
            elif p.name == 'timeout':
                self.timeout = self.freshness.timeout = float(p.value)
        return SetParametersResult(successful=True)

    # --- diagnostics ---

    def _report(self) -> None:
        level, message = self._status
        error = self._state_writer.error if self._state_writer is not None else None
        if error is not None:
            level, message = max(level, WARN), f'{message}; {self.state_file} not written: {error}'
        self._diag.report(level, message, DriverStatus(
            mode=self.mode, active=self.active, accepted=self.accepted, rejected=self.rejected, dropped=self.dropped,
            lengths=tuple(float(v) for v in self.actuators.positions),
            stuck_legs=tuple(int(i) + 1 for i in np.flatnonzero(self.actuators.stuck)),
            **DriverStatus.grippers(self.grippers.closed), gripper_refusals=self.gripper_refusals,
            state_file_error='' if error is None else str(error),
            **self.ages.summary(self.get_clock().now().nanoseconds * 1e-9)))

    def _set_status(self, level, message: str) -> None:
        if (level, message) != self._status:
            self._status = (level, message)
            if level != OK:
                self.get_logger().warning(message, throttle_duration_sec=1.0)
            self._report()

    # --- commands ---

    def _parse(self, msg: JointState) -> tuple[np.ndarray, np.ndarray | None]:
        try:
            lengths = lengths_from_joint_state(msg)
        except ValueError as exc:
            raise RejectedCommand(str(exc)) from None
        g = self.geometry
        if np.any(lengths < g.min_length) or np.any(lengths > g.max_length):
            legs = [LEG_NAMES[i] for i in np.flatnonzero((lengths < g.min_length) | (lengths > g.max_length))]
            raise RejectedCommand(f'lengths of {legs} outside the stroke [{g.min_length}, {g.max_length}] m')
        rings = None
        if self.rings is not None and any(name in msg.name for name in self.ring_names):
            index = {n: i for i, n in enumerate(msg.name)}
            rings = self.ring_reference.copy()
            for k, name in enumerate(self.ring_names):
                if name in index:
                    rings[k] = msg.position[index[name]]
            if not np.all(np.isfinite(rings)) or np.any(rings < self.rings.min_position) or \
                    np.any(rings > self.rings.max_position):
                raise RejectedCommand(f'ring rotations {rings} outside their limits')
        now = self.get_clock().now().nanoseconds * 1e-9
        self.freshness.check(stamp_to_seconds(msg.header.stamp), now)  # content errors first
        return lengths, rings

    def _on_command(self, msg: JointState) -> None:
        if not self.active:
            self.rejected += 1
            self._set_status(WARN, f'command rejected: the driver is inactive; activate through '
                                   f'{self.get_name()}/change_state')
            return
        stamp = stamp_to_seconds(msg.header.stamp)
        if stamp != 0.0:
            now = self.get_clock().now().nanoseconds * 1e-9
            self.ages.add(now, now - stamp, stale=now - stamp > self.timeout)
        try:
            lengths, rings = self._parse(msg)
        except RejectedCommand as exc:
            self.rejected += 1
            self._set_status(WARN, f'command rejected, tracking the last accepted one: {exc}')
            return
        self.accepted += 1
        self._wake()
        self.reference = lengths
        if rings is not None:
            self.ring_reference = rings
        self._last_command_time = time.monotonic()
        self._set_status(OK, f'{self.mode.value} actuators tracking actuators/command')
        if self.publish_on_command:
            self._step()
            self._publish_state()

    # --- simulation ---

    def _step(self) -> None:
        t = time.monotonic()
        dt = min(t - self._last_step, self._max_dt)
        self._last_step = t
        if (self.hold_when_silent and self._last_command_time is not None
                and t - self._last_command_time > self.timeout):
            self.reference = self.actuators.positions
            if self.rings is not None:
                self.ring_reference = self.rings.positions.copy()
            self._last_command_time = None
            self._set_status(STALE, f'no command for {self.timeout:.3f} s: holding')
        try:
            self.actuators.step(self.reference, dt)
        except RuntimeError as exc:
            dyn = self.actuators.dynamics
            dyn.reset(dyn.position, dyn.quaternion_xyzw)
            self.reference = self.actuators.positions
            self._set_status(ERROR, f'dynamics failed ({exc}): reset at rest, holding')
        if self.mode is ActuatorMode.KINEMATIC:
            self.static_efforts.update(self.actuators.positions, dt)
        if self.rings is not None:
            self.rings.step(self.ring_reference, dt)

    def _on_tick(self) -> None:
        self._step()
        self._publish_state()
        if not self._resting and self._at_rest():
            self._set_tick_rate(self.idle_rate)

    def _at_rest(self) -> bool:
        """Nothing moves and nothing was commanded for 0.5 s (kinematic mode: the dynamics
        always runs at ``rate``)."""
        if self.mode is not ActuatorMode.KINEMATIC or self.idle_rate >= self.rate:
            return False
        if self._last_command_time is not None and time.monotonic() - self._last_command_time < 0.5:
            return False
        moving = np.any(np.abs(self.actuators.velocities) > 1e-9) or (
            self.rings is not None and np.any(np.abs(self.rings.velocities) > 1e-9))
        return not moving and np.array_equal(self.reference, self.actuators.positions)

    def _set_tick_rate(self, rate: float) -> None:
        self._resting = rate < self.rate
        self._tick_timer.timer_period_ns = int(1e9 / rate)

    def _wake(self) -> None:
        """Back to the full rate at once (a command came, a gripper switched)."""
        if self._resting:
            self._set_tick_rate(self.rate)
            self._last_step = time.monotonic()

    def _publish_state(self) -> None:
        if self.faults.drop():
            self.dropped += 1
            return
        a = self.actuators
        efforts = a.efforts if self.mode is ActuatorMode.DYNAMIC else self.static_efforts.efforts
        positions, velocities = self.faults.measure(a.positions), a.velocities
        if self.rings is not None:
            positions = np.concatenate([positions, self.rings.positions])
            velocities = np.concatenate([velocities, self.rings.velocities])
            efforts = np.concatenate([efforts, np.zeros(len(self.ring_names))])
        self._state_pub.publish(joint_state_msg(self.get_clock().now().to_msg(), positions, velocities,
                                                efforts, names=self.names))

    # --- grippers ---

    def _publish_grippers(self) -> None:
        self._grippers_pub.publish(joint_state_msg(self.get_clock().now().to_msg(),
                                                   self.grippers.positions(), names=RINGS))

    def _on_gripper(self, ring: str, request, response):
        before = self.grippers.positions()
        if not self.active:
            response.success = False
            response.message = (f'refused: the driver is inactive; activate through '
                                f'{self.get_name()}/change_state')
        else:
            response.success, response.message = self.grippers.set(ring, close=bool(request.data))
        if not response.success:
            self.gripper_refusals += 1
            self.get_logger().warning(response.message, throttle_duration_sec=1.0)
            self._report()
        if self.grippers.positions() != before:
            self._save_state()
            self._publish_grippers()
            self._report()
        return response


def main(args=None) -> None:
    run_nodes([DriverNode], args)


if __name__ == '__main__':
    main()
