"""master_node: the simulated parallel master robot (pure core: :mod:`rrps_teleop.master`).

The handle moves towards ``master/target_pose`` or a scripted ``trajectory``; the node publishes
its leg lengths and FK (topics and parameters: docs/usage.md, docs/parameters.md), and
``master/feedback`` pushes the simulated handle back by its compliances. With ``hardware`` other
than ``simulated`` the encoders give the lengths and master/feedback becomes leg forces (eq. 1,
J^T f = wrench); a hardware fault stops the publications and the force output (ERROR) until
``master_node/reset_faults``.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from rrps_description.geometry import load_robot
from rrps_description.pose import validate_pose
from rrps_description.rotations import quat_multiply_xyzw, rotation_vector_to_quat_xyzw
from rrps_hardware.interface import HardwareConfig
from rrps_hardware.registry import hardware_parameters, master_hardware_class, registered_master_hardware
from rrps_interfaces.teleop import MASTER_FEEDBACK, MASTER_FRAME, MASTER_POSE, MASTER_STATE, MASTER_TARGET_POSE
from rrps_kinematics import forward_kinematics, inverse_kinematics
from rrps_kinematics.jacobian import leg_forces
from rrps_runtime.diagnostics import ERROR, OK, OPERATOR_STATION, WARN, Diagnostics, log_status
from rrps_runtime.messages import joint_state_msg, pose_from_msg, pose_to_msg
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_runtime.scheduling import scheduling_parameters
from rrps_runtime.supervision import OPERATOR_RT_PRIORITY
from rrps_teleop.master import TRAJECTORIES, HandleMotion, MasterModel, scripted_pose

__all__ = ['MasterNode', 'PARAMETERS', 'hosted_parameters', 'main']

#: master/feedback older than this [s] is ignored (the teleop node sends it at 20 Hz).
FEEDBACK_TIMEOUT = 0.2

#: master_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('master_node', 'rrps_teleop', [
    dataclasses.replace(ROBOT, default='master_robot'),
    Parameter('hardware', 'simulated', "the master: simulated (a handle model), or the name of its hardware "
              '(an rrps.master_hardware entry point, e.g. canopen)'),
    Parameter('frame_id', MASTER_FRAME, 'frame of master/target_pose and master/pose'),
    Parameter('rate', 200.0, 'encoder (publication) rate', unit='Hz', range=(1.0, 2000.0)),
    Parameter('idle_rate', 50.0, 'encoder rate while the handle rests at its target', unit='Hz',
              range=(1.0, 2000.0)),
    Parameter('trajectory', 'none', 'scripted motion of the handle', choices=TRAJECTORIES, dynamic=True),
    Parameter('amplitude', 0.005, 'scripted translation amplitude', unit='m', range=(0.0, 0.05), dynamic=True),
    Parameter('period', 10.0, 'scripted trajectory period', unit='s', range=(0.1, 1000.0), dynamic=True),
    Parameter('angular_amplitude', 0.05, 'lissajous rotation amplitude', unit='rad', range=(0.0, 1.0),
              dynamic=True),
    Parameter('max_linear_speed', 0.05, 'handle speed limit', unit='m/s', range=(1e-4, 10.0)),
    Parameter('max_angular_speed', 1.0, 'handle angular speed limit', unit='rad/s', range=(1e-4, 100.0)),
    Parameter('feedback_compliance', 2e-4, "how far master/feedback pushes the handle back (the operator's "
              'hand yields)', unit='m/N', range=(0.0, 0.1)),
    Parameter('feedback_angular_compliance', 0.05, 'how far master/feedback turns the handle back',
              unit='rad/(N m)', range=(0.0, 10.0)),
    *scheduling_parameters(OPERATOR_RT_PRIORITY),
])
#: The parameter that names the master's hardware whose own parameters the node declares.
HOSTED_BY = 'hardware'


def hosted_parameters() -> dict[str, NodeParameters]:
    """{name: the parameters master_node declares for it} of every installed master hardware."""
    return {name: hardware_parameters(PARAMETERS, load()) for name, load in registered_master_hardware().items()}


class MasterNode(Node):
    """The master robot: operator or scripted handle in, encoder lengths and FK pose out."""

    def __init__(self, **kwargs):
        super().__init__('master_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        self.frame_id = values['frame_id']
        self.rate = values['rate']
        self.idle_rate = values['idle_rate']
        self.trajectory = values['trajectory']
        self.amplitude = values['amplitude']
        self.period = values['period']
        self.angular_amplitude = values['angular_amplitude']
        self.feedback_compliance = values['feedback_compliance']
        self.feedback_angular_compliance = values['feedback_angular_compliance']
        self.model = MasterModel(self.geometry, max_linear_speed=values['max_linear_speed'],
                                 max_angular_speed=values['max_angular_speed'])
        self._target = (self.model.position.copy(), self.model.quaternion_xyzw.copy())
        self._fk_pose = (self.model.position.copy(), self.model.quaternion_xyzw.copy())
        self._fk_lengths = self.model.lengths.copy()
        self._start = time.monotonic()
        self._last_tick: float | None = None
        self._status = (OK, 'holding the home pose')
        self._diag = Diagnostics(self, 'master robot', hardware_id=OPERATOR_STATION)
        self._tap = RecordingTap(self)
        self._state_pub = self._tap.create_publisher(JointState, MASTER_STATE, STATE_QOS)
        self._pose_pub = self._tap.create_publisher(PoseStamped, MASTER_POSE, STATE_QOS)
        self.create_subscription(PoseStamped, MASTER_TARGET_POSE, self._on_target, COMMAND_QOS)
        self._feedback: tuple[float, np.ndarray, np.ndarray] | None = None
        self.create_subscription(WrenchStamped, MASTER_FEEDBACK, self._on_feedback, COMMAND_QOS)
        self.hardware = None
        if values['hardware'] != 'simulated':
            self._start_hardware(values)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._tick_timer = self.create_timer(1.0 / self.rate, self._on_tick)
        self._resting = False
        self.create_timer(0.5, self._report)

    def _start_hardware(self, values) -> None:
        """Configure and activate the master's hardware; ValueError (the reason) when it fails."""
        hardware = master_hardware_class(values['hardware'])
        config = HardwareConfig(self.geometry, declare_parameters(self, hardware_parameters(PARAMETERS, hardware)))
        self.hardware = hardware()
        for verb in (lambda: self.hardware.on_configure(config),
                     self.hardware.on_activate):
            outcome = verb()
            if not outcome.ok:
                self.hardware.on_shutdown()
                self.destroy_node()
                raise ValueError(f'{values["hardware"]} master: {outcome.reason}')
        self._status = (OK, f'{values["hardware"]} master: encoders and force output on')
        self.create_service(Trigger, f'{self.get_name()}/reset_faults', self._on_reset_faults)

    def _on_reset_faults(self, request, response):
        """The operator's fault reset of the master's hardware, then its force output on again."""
        result = self.hardware.reset_faults()
        response.success, response.message = result.ok, result.message
        if result.ok:
            activated = self.hardware.on_activate()
            response.success, response.message = activated.ok, activated.reason or result.message
        return response

    def destroy_node(self) -> None:
        if getattr(self, 'hardware', None) is not None:
            self.hardware.on_shutdown()
        super().destroy_node()

    def _apply_parameters(self, parameters) -> None:
        for p in parameters:
            if p.name in ('trajectory', 'amplitude', 'period', 'angular_amplitude'):
                setattr(self, p.name, p.value)
            if p.name == 'trajectory':
                self._start = time.monotonic()  # scripted time restarts; the handle walks there
                self._target = (self.model.position.copy(), self.model.quaternion_xyzw.copy())

    def _set_status(self, level, message: str) -> None:
        if (level, message) != self._status:
            self._status = (level, message)
            self._report()
            log_status(self.get_logger(), level, message)

    def _report(self) -> None:
        level, message = self._status
        self._diag.report(level, message, {'trajectory': self.trajectory, 'lengths': self.model.lengths,
                                           'position': self.model.position})

    def _on_target(self, msg: PoseStamped) -> None:
        if self.trajectory != 'none':
            self._set_status(WARN, f'master/target_pose ignored: trajectory {self.trajectory} is running')
            return
        if msg.header.frame_id != self.frame_id:
            self._set_status(WARN, f'master/target_pose rejected: frame_id {msg.header.frame_id!r} '
                                   f'is not {self.frame_id!r}')
            return
        try:
            target = validate_pose(*pose_from_msg(msg), what='master/target_pose')
        except ValueError as exc:
            self._set_status(WARN, f'rejected {exc}')
            return
        if not (np.array_equal(target[0], self._target[0])
                and np.array_equal(target[1], self._target[1])):
            self._wake()
        self._target = target

    def _on_feedback(self, msg: WrenchStamped) -> None:
        f, t = msg.wrench.force, msg.wrench.torque
        force, torque = np.array([f.x, f.y, f.z]), np.array([t.x, t.y, t.z])
        if msg.header.frame_id != self.frame_id or not (np.all(np.isfinite(force))
                                                        and np.all(np.isfinite(torque))):
            self._set_status(WARN, f'master/feedback rejected: frame {msg.header.frame_id!r} '
                                   'or a value not finite')
            return
        self._feedback = (time.monotonic(), force, torque) if np.any(force) or np.any(torque) else None
        if self._feedback is not None:
            self._wake()

    def _yielding_target(self, now: float):
        """The handle's target moved back by the fixture's wrench (a fresh one: < 0.2 s old): the
        simulated operator's hand yields ``feedback_compliance`` per newton."""
        position, quaternion = self._target
        if self._feedback is None or now - self._feedback[0] > FEEDBACK_TIMEOUT:
            return position, quaternion
        _, force, torque = self._feedback
        q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(self.feedback_angular_compliance * torque),
                               quaternion)
        return position + self.feedback_compliance * force, q / np.linalg.norm(q)

    def _wake(self) -> None:
        """Back to the encoder ``rate`` (the handle has somewhere to go)."""
        if self._resting:
            self._resting = False
            self._tick_timer.timer_period_ns = int(1e9 / self.rate)

    def _rest_if_idle(self, note) -> None:
        """At ``idle_rate`` while the handle rests at its target with nothing pushing it."""
        pushed = self._feedback is not None and time.monotonic() - self._feedback[0] <= FEEDBACK_TIMEOUT
        idle = (self.trajectory == 'none' and note.motion is HandleMotion.FULL
                and self.idle_rate < self.rate and not pushed
                and np.array_equal(self.model.position, self._target[0]))
        if idle and not self._resting:
            self._resting = True
            self._tick_timer.timer_period_ns = int(1e9 / self.idle_rate)
        elif not idle:
            self._wake()

    def _feedback_forces(self, now: float) -> np.ndarray | None:
        """The leg forces that put the (fresh) feedback wrench on the master's ring_b: J^T f = w."""
        if self._feedback is None or now - self._feedback[0] > FEEDBACK_TIMEOUT:
            return None
        _, force, torque = self._feedback
        try:
            return -leg_forces(inverse_kinematics(self.geometry, *self._fk_pose), np.concatenate([force, torque]))
        except np.linalg.LinAlgError:
            return None

    def _hardware_tick(self, now: float) -> None:
        sample = self.hardware.read(now)
        if sample.faults or sample.lost:
            reason = '; '.join(map(str, sample.faults)) or 'the bus is lost'
            self._set_status(ERROR, f'master hardware: {reason}: force output off; master_node/reset_faults')
            return
        result = self.hardware.write(now, self._feedback_forces(now))
        if not result.ok:
            self._set_status(WARN, f'master force output: {result.message}')
        self._publish(sample.lengths)

    def _publish(self, lengths: np.ndarray) -> None:
        """master/actuators/state and the FK pose of ``lengths``."""
        stamp = self.get_clock().now().to_msg()
        self._state_pub.publish(joint_state_msg(stamp, lengths))
        if not np.array_equal(lengths, self._fk_lengths):  # a resting handle: the same pose
            fk = forward_kinematics(self.geometry, lengths, *self._fk_pose)
            if fk.converged:
                self._fk_pose, self._fk_lengths = (fk.position, fk.quaternion_xyzw), lengths.copy()
            else:
                self._set_status(ERROR, f'master FK did not converge (residual {fk.residual:.3g} m): '
                                        'holding the last estimate')
        self._pose_pub.publish(pose_to_msg(*self._fk_pose, frame_id=self.frame_id, stamp=stamp))

    def _on_tick(self) -> None:
        now = time.monotonic()
        if self.hardware is not None:
            self._hardware_tick(now)
            return
        dt = 0.0 if self._last_tick is None else now - self._last_tick
        self._last_tick = now
        if self.trajectory != 'none':
            self._target = scripted_pose(self.trajectory, now - self._start, self.geometry.home_position,
                                         self.geometry.home_quaternion_xyzw, amplitude=self.amplitude,
                                         period=self.period, angular_amplitude=self.angular_amplitude)
        note = self.model.move_toward(*self._yielding_target(now), dt)
        if note.motion is HandleMotion.STOPPED:
            self._set_status(WARN, f'handle {note}')
        else:
            self._set_status(OK, f'trajectory {self.trajectory}' if self.trajectory != 'none'
                             else 'following master/target_pose')
        self._publish(self.model.lengths)
        self._rest_if_idle(note)


def main(args=None) -> None:
    run_nodes([MasterNode], args)
