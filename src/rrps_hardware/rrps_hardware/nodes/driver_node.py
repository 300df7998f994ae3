"""driver_node: the robot's hardware in ROS. actuators/command -> actuators/state, plus the grippers.

A lifecycle node hosting the implementation its ``hardware`` parameter names
(:mod:`rrps_hardware.registry`), each cycle ``write`` then ``read``. **Inactive** after start-up:
nothing moves until ``activate``; a fault deactivates it until ``driver_node/reset_faults``. A
malformed, unstamped, out-of-stroke or stale command is not acted on; the grippers are never both
open. Topics and parameters: docs/usage.md, docs/parameters.md; faults: docs/connecting-a-robot.md.

    driver_node --ros-args -r __ns:=/rrps -p robot:=pole_climber
"""

from __future__ import annotations

import time
import traceback

import numpy as np
from geometry_msgs.msg import TransformStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.lifecycle import LifecycleNode, State, TransitionCallbackReturn
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from rrps_description.geometry import load_robot
from rrps_description.names import LEG_NAMES, RINGS
from rrps_hardware.commands import checked_command, ring_joints
from rrps_hardware.interface import BusState, CallbackReturn, Command, HardwareConfig, Result, ReturnType, Transition
from rrps_hardware.registry import hardware_class, hardware_parameters, registered_hardware
from rrps_hardware.setpoints import MAX_STEP_PERIODS
from rrps_hardware.support_follower import DEFAULT_TIMEOUT, SupportFollower
from rrps_interfaces.climb import SUPPORT_POSE
from rrps_interfaces.driver import GRIPPERS_STATE, RESET_FAULTS, DriverStatus, SupportSource, gripper_service
from rrps_interfaces.kinematics import ACTUATORS_COMMAND, ACTUATORS_STATE
from rrps_runtime.collector import freeze_new_objects
from rrps_runtime.diagnostics import ERROR, OK, STALE, WARN, Diagnostics, log_status
from rrps_runtime.freshness import CommandAges, CommandFreshness, RejectedCommand
from rrps_runtime.messages import joint_state_msg, lengths_from_joint_state, stamp_to_seconds, transform_from_msg
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, LATCHED_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_runtime.scheduling import request_of, scheduling_parameters
from rrps_runtime.supervision import CONTROL_RT_PRIORITY

__all__ = ['DriverNode', 'PARAMETERS', 'hosted_parameters', 'main']

#: driver_node's own parameters; the hardware's follow, declared once ``hardware`` names it.
PARAMETERS = NodeParameters('driver_node', 'rrps_hardware', [
    ROBOT,
    Parameter('hardware', 'simulated', 'the hardware implementation: a name of the rrps.hardware entry points'),
    Parameter('rate', 500.0, 'actuators/state publication rate', unit='Hz', range=(1.0, 5000.0)),
    Parameter('idle_rate', 50.0, 'actuators/state rate while the robot rests (every actuator at its target, no '
              'command for 0.5 s); equal to rate: always rate', unit='Hz', range=(1.0, 5000.0)),
    Parameter('timeout', 0.1, 'a command stamped longer ago than this is not acted on', unit='s',
              range=(1e-3, 60.0), dynamic=True),
    Parameter('publish_on_command', False, 'also publish actuators/state at once when a command is accepted'),
    Parameter('hold_when_silent', False, 'stop the actuators where they are when no command arrived for timeout s'),
    Parameter('auto_activate', False, 'activate at start (otherwise: change_state activate)'),
    Parameter('support_timeout', DEFAULT_TIMEOUT, 'odometry/support older than this is not followed: the last '
              'known attitude of the supporting ring is kept (status WARN)', unit='s', range=(0.01, 600.0)),
    *scheduling_parameters(CONTROL_RT_PRIORITY),
])
#: The parameter that names the hardware whose own parameters the driver declares.
HOSTED_BY = 'hardware'


def hosted_parameters() -> dict[str, NodeParameters]:
    """{name: the parameters driver_node declares for it} of every installed hardware."""
    return {name: hardware_parameters(PARAMETERS, load()) for name, load in registered_hardware().items()}


class DriverNode(LifecycleNode):
    """The hardware of one robot as a lifecycle node (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('driver_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        g = self.geometry = load_robot(values['robot'])
        self.hardware_name = values['hardware']
        hardware = hardware_class(self.hardware_name)
        owned = hardware_parameters(PARAMETERS, hardware)
        self._config = HardwareConfig(g, declare_parameters(self, owned), scheduling=request_of(values))
        #: The hardware's parameters the driver passes on to it while it runs.
        self._dynamic = frozenset(p.name for p in owned if p.dynamic)
        self.hardware = hardware()
        self.rate, self.idle_rate, self.timeout = values['rate'], values['idle_rate'], values['timeout']
        self.publish_on_command, self.hold_when_silent = values['publish_on_command'], values['hold_when_silent']
        self.ring_names = ring_joints(g)
        self.names = list(LEG_NAMES) + self.ring_names
        self.active = False
        self.accepted = self.rejected = self.dropped = self.gripper_refusals = 0
        self.ages, self.freshness = CommandAges(), CommandFreshness(self.timeout)
        self._command: Command | None = None
        self._last_command_time: float | None = None
        self._last_step, self._max_dt = time.monotonic(), MAX_STEP_PERIODS / self.rate
        self._status = (WARN, f'inactive: activate through {self.get_name()}/change_state')
        self._refusal = ''
        if self.trigger_configure() != TransitionCallbackReturn.SUCCESS:
            self.destroy_node()
            raise ValueError(f'{self.hardware_name} hardware: {self._refusal}')
        self.label = self.hardware.label or f'{self.hardware_name} hardware'
        start = self.hardware.support  # None: hardware in the real world's gravity
        self._support = None if start is None else SupportFollower(start, timeout=values['support_timeout'])
        self._tap = RecordingTap(self)
        self._state_pub = self._tap.create_publisher(JointState, ACTUATORS_STATE, STATE_QOS)
        self._grippers_pub = self._tap.create_publisher(JointState, GRIPPERS_STATE, STATE_QOS)
        self.create_subscription(JointState, ACTUATORS_COMMAND, self._on_command, COMMAND_QOS)
        for ring in RINGS:
            self.create_service(SetBool, gripper_service(ring),
                                lambda request, response, ring=ring: self._on_gripper(ring, request, response))
        self.create_service(Trigger, RESET_FAULTS, self._on_reset_faults)
        if self._support is not None:
            self.create_subscription(TransformStamped, SUPPORT_POSE, self._on_support, LATCHED_QOS)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._diag = Diagnostics(self, self.label, hardware_id=g.name)
        self._tick_timer = self.create_timer(1.0 / self.rate, self._on_tick)
        self._resting = False
        self.create_timer(0.05, self._publish_grippers)
        self.create_timer(0.5, self._report)
        if values['auto_activate']:
            self.trigger_activate()

    @property
    def reference(self) -> np.ndarray:
        """The leg lengths [m] the actuators follow: the last accepted command, or where they hold."""
        return self.state.targets

    # --- lifecycle: the hardware's verbs ---

    def _transition(self, verb: str, *args) -> TransitionCallbackReturn:
        """The lifecycle return of the hardware's verb ``verb`` called with ``args``: a refusal's
        reason is logged and kept, as is what a successful verb had to say (what it skipped) as a
        warning; an exception it raises is an ERROR with its text, its traceback logged (rclpy's
        lifecycle would turn it into an error without a word)."""
        try:
            outcome = getattr(self.hardware, verb)(*args)
        except Exception as exc:
            self.get_logger().error(f'{self.label} {verb} raised:\n{traceback.format_exc()}')
            outcome = Transition(CallbackReturn.ERROR, f'{verb} failed: {type(exc).__name__}: {exc}')
        if outcome.ok:
            freeze_new_objects()  # what the hardware built (a bus, its devices), as the node at start-up
            if outcome.reason:
                self.get_logger().warning(outcome.reason)
            return TransitionCallbackReturn.SUCCESS
        self._refusal = outcome.reason
        self.get_logger().error(outcome.reason)
        return getattr(TransitionCallbackReturn, outcome.code.name)  # FAILURE, or ERROR: on to on_error

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        result = self._transition('on_configure', self._config)
        if result == TransitionCallbackReturn.SUCCESS:
            self.state = self.hardware.read(time.monotonic(), 0.0)
        return result

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = self._transition('on_activate')
        if result != TransitionCallbackReturn.SUCCESS:
            self._set_status(ERROR, f'activation refused: {self._refusal}')
            return result
        self._drop_command()
        self.active = True
        self._set_status(OK, f'{self.label} active, holding: waiting for actuators/command')
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self.active = False
        self._drop_command()
        self._set_status(WARN, f'inactive: holding; activate through {self.get_name()}/change_state')
        self._transition('on_deactivate')
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        return self._transition('on_cleanup')

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        self.active = False
        return self._transition('on_shutdown')

    def on_error(self, state: State) -> TransitionCallbackReturn:
        self.active = False
        return self._transition('on_error')

    def destroy_node(self) -> None:
        self.hardware.on_shutdown()  # the hardware keeps its last state before the process ends
        super().destroy_node()

    def _drop_command(self) -> None:
        """Forget the last command (the hardware holds: no jump towards it later)."""
        self._command = self._last_command_time = None

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        """``timeout``, and the hardware's run-time parameters (it refuses what it does not take)."""
        changes = {p.name: p.value for p in parameters if p.name in self._dynamic}
        result = self.hardware.set_parameters(changes) if changes else None
        if result is not None and not result.ok:
            return SetParametersResult(successful=False, reason=result.message)
        for p in parameters:
            if p.name == 'timeout':
                self.timeout = self.freshness.timeout = float(p.value)
        return SetParametersResult(successful=True)

    # --- diagnostics ---

    def _report(self) -> None:
        level, message = self._status
        s, error = self.state, self.state.persist_error
        if error:
            level, message = max(level, WARN), f'{message}; {error}'
        support = self._follow_support()
        if support.get('support_source') is SupportSource.STALE:
            level, message = max(level, WARN), (f'{message}; {SUPPORT_POSE} silent for {support["support_age"]:.1f} s: '
                                                f'keeping the last known attitude of {support["support_ring"]}')
        self._diag.report(level, message, DriverStatus(
            active=self.active, accepted=self.accepted, rejected=self.rejected, dropped=self.dropped,
            lengths=tuple(float(v) for v in s.positions), **self.hardware.status_values(),
            **DriverStatus.grippers(s.grippers),
            gripper_refusals=self.gripper_refusals, state_file_error=error, hardware=self.hardware_name,
            faults=tuple(f'{f.actuator}:{f.kind.value}' for f in s.faults),
            **support, **self.ages.summary(self.get_clock().now().nanoseconds * 1e-9)))

    def _set_status(self, level, message: str) -> None:
        if (level, message) != self._status:
            self._status = (level, message)
            log_status(self.get_logger(), level, message)
            self._report()

    # --- the supporting ring's attitude ---

    def _on_support(self, msg: TransformStamped) -> None:
        """The odometry's supporting ring (kept when well-formed), followed at once."""
        _, q = transform_from_msg(msg)
        if not self._support.on_message(msg.header.frame_id, msg.child_frame_id, q, time.monotonic()):
            self.get_logger().warning(f'{SUPPORT_POSE} rejected, the attitude stays: {self._support.rejection}',
                                      throttle_duration_sec=5.0)
        self._follow_support()

    def _follow_support(self) -> dict:
        """Ground the odometry's attitude when it is fresh and for the ring that grips; the
        status values of the support in use ({} for hardware in the real world's gravity)."""
        current = self.hardware.support
        if self._support is None or current is None:
            return {}
        new = self._support.update(current, time.monotonic())
        if new is not None:
            result = self.hardware.set_support(new)
            if not result.ok:
                self.get_logger().warning(f'{SUPPORT_POSE} not followed: {result.message}', throttle_duration_sec=5.0)
        return self._support.report(time.monotonic()).status_values(self.hardware.support)

    # --- commands ---

    def _parse(self, msg: JointState) -> Command:
        try:
            lengths = lengths_from_joint_state(msg)
        except ValueError as exc:
            raise RejectedCommand(str(exc)) from None
        rings = {name: p for name, p in zip(msg.name, msg.position) if name in self.ring_names}
        stamp = stamp_to_seconds(msg.header.stamp)
        command = checked_command(self.geometry, lengths, rings, self.state.ring_targets, stamp=stamp or None)
        self.freshness.check(stamp, self._now())  # content errors first
        return command

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_command(self, msg: JointState) -> None:
        if not self.active:
            self.rejected += 1
            if self._status[0] != ERROR:   # a fault's status stands: said once, not at the command rate
                self._set_status(WARN, f'command rejected: the driver is inactive; activate through '
                                       f'{self.get_name()}/change_state')
            return
        stamp = stamp_to_seconds(msg.header.stamp)
        if stamp != 0.0:
            now = self._now()
            self.ages.add(now, now - stamp, stale=now - stamp > self.timeout)
        try:
            self._command = self._parse(msg)
        except RejectedCommand as exc:
            self.rejected += 1
            self._set_status(WARN, f'command rejected, tracking the last accepted one: {exc}')
            return
        self.accepted += 1
        self._wake()
        self._last_command_time = time.monotonic()
        self._set_status(OK, f'{self.label} tracking actuators/command')
        if self.publish_on_command:
            self._cycle()
        elif self.hardware.OWN_CYCLE and not self.hardware.write(self._last_command_time, 0.0, self._command).ok:
            self._command = None   # refused (a fault): the next tick says why

    # --- the hardware's cycle ---

    def _cycle(self) -> None:
        """write (the last accepted command), read, publish what was read."""
        t = time.monotonic()
        dt, self._last_step = min(t - self._last_step, self._max_dt), t
        if self.hold_when_silent and self._last_command_time is not None and t - self._last_command_time > self.timeout:
            self._drop_command()
            self.hardware.hold()
            self._set_status(STALE, f'no command for {self.timeout:.3f} s: holding')
        result = self.hardware.write(t, dt, self._command)
        if not result.ok:  # the hardware stopped and holds: the last command is void
            self._command = None
        s = self.state = self.hardware.read(t, dt)
        if s.faults:
            if self.active:
                self.trigger_deactivate()
            self._set_status(ERROR, f'{"; ".join(map(str, s.faults))}: holding, inactive; reset the faults '
                                    f'({self.get_name()}/reset_faults), then activate')
        elif not result.ok:
            self._set_status(ERROR, result.message)
        if s.lost:
            self.dropped += 1
            return
        self._state_pub.publish(joint_state_msg(
            self.get_clock().now().to_msg(), np.concatenate([s.positions, s.ring_positions]),
            np.concatenate([s.velocities, s.ring_velocities]),
            np.concatenate([s.efforts, np.zeros(len(s.ring_positions))]), names=self.names))

    def _on_tick(self) -> None:
        self._cycle()
        recent = self._last_command_time is not None and time.monotonic() - self._last_command_time < 0.5
        if not self._resting and self.idle_rate < self.rate and not recent and self.state.at_rest():
            self._set_tick_rate(self.idle_rate)

    def _set_tick_rate(self, rate: float) -> None:
        self._resting = rate < self.rate
        self._tick_timer.timer_period_ns = int(1e9 / rate)

    def _wake(self) -> None:
        """Back to the full rate at once (a command came, a gripper switched)."""
        if self._resting:
            self._set_tick_rate(self.rate)
            self._last_step = time.monotonic()

    # --- faults ---

    def _on_reset_faults(self, request, response):
        """The operator's fault reset: refused while active or while the bus is lost."""
        if self.active:
            result = Result(ReturnType.ERROR, 'refused: the driver is active (a fault deactivates it)')
        elif self.state.bus is BusState.LOST:
            result = Result(ReturnType.ERROR, 'refused: the bus is lost')
        else:
            result = self.hardware.reset_faults()
        response.success, response.message = result.ok, result.message
        if result.ok:
            self.state = self.hardware.read(time.monotonic(), 0.0)
            self._set_status(WARN, f'{result.message}; inactive: activate through {self.get_name()}/change_state')
        else:
            self.get_logger().warning(f'fault reset refused: {result.message}')
        return response

    # --- grippers ---

    def _publish_grippers(self) -> None:
        self._grippers_pub.publish(joint_state_msg(self.get_clock().now().to_msg(),
                                                   [float(self.state.grippers[r]) for r in RINGS], names=RINGS))

    def _on_gripper(self, ring: str, request, response):
        before = dict(self.state.grippers)
        result = self.hardware.set_gripper(ring, close=bool(request.data)) if self.active else Result(
            ReturnType.ERROR, f'refused: the driver is inactive; activate through {self.get_name()}/change_state')
        response.success, response.message = result.ok, result.message
        if not result.ok:
            self.gripper_refusals += 1
            self.get_logger().warning(result.message, throttle_duration_sec=1.0)
            self._report()
            return response
        self._wake()
        self._cycle()  # the grippers as they are now
        if self.state.grippers != before:
            self._publish_grippers()
            self._report()
        return response


def main(args=None) -> None:
    run_nodes([DriverNode], args)


if __name__ == '__main__':
    main()
