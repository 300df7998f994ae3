"""fk_node: actuators/state (measured leg lengths) -> pose (PoseStamped a_T_b, frame ring_a).

Newton direct kinematics (§2.2) seeded from the last estimate and guarded against assembly-mode
jumps (:class:`rrps_kinematics.tracking.PoseTracker`); a pose per sample, with its stamp. A refused
update publishes nothing and /diagnostics says why (docs/usage.md, 'The ROS interface').
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from rrps_description.geometry import load_robot
from rrps_description.names import RING_A_FRAME
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE, FkStatus
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.limits import inverse_condition_number
from rrps_kinematics.tracking import PoseTracker
from rrps_runtime.diagnostics import ERROR, OK, STALE, WARN, Diagnostics
from rrps_runtime.messages import lengths_from_joint_state, pose_to_msg
from rrps_runtime.parameter_schema import ROBOT, NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import STATE_QOS
from rrps_runtime.recording_tap import RecordingTap
from rrps_runtime.scheduling import scheduling_parameters
from rrps_runtime.supervision import CONTROL_RT_PRIORITY

__all__ = ['FkNode', 'main']


#: fk_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('fk_node', 'rrps_kinematics', [
    ROBOT,
    Parameter('frame_id', RING_A_FRAME, 'frame_id of the published pose'),
    Parameter('tolerance', 1e-12, 'Newton convergence: largest leg-length residual', unit='m',
              range=(1e-15, 1e-3), dynamic=True),
    Parameter('max_iterations', 30, 'Newton iterations per solve', range=(1, 1000), dynamic=True),
    Parameter('max_jump', 0.05, 'a larger change between estimates (translation + rotation x characteristic '
              'length) is re-solved by continuation; 0 disables the check', unit='m', range=(0.0, 10.0),
              dynamic=True),
    Parameter('continuation_steps', 20, 'steps of the continuation solve', range=(1, 1000), dynamic=True),
    *scheduling_parameters(CONTROL_RT_PRIORITY),
])


class FkNode(Node):
    """Direct kinematics of the measured actuator lengths, warm-started."""

    def __init__(self, **kwargs):
        super().__init__('fk_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        self.geometry = load_robot(values['robot'])
        self.frame_id = values['frame_id']
        self.tracker = PoseTracker(self.geometry, max_jump=values['max_jump'],
                                   continuation_steps=values['continuation_steps'],
                                   tolerance=values['tolerance'], max_iterations=values['max_iterations'])
        self.solved = 0
        self.failed = 0
        self._last: dict = {}
        self._solved_lengths: np.ndarray | None = None
        self._pose_msg: PoseStamped | None = None
        self._status = (STALE, 'waiting for actuators/state')
        self._tap = RecordingTap(self)
        self._pub = self._tap.create_publisher(PoseStamped, POSE, STATE_QOS)
        self.create_subscription(JointState, ACTUATORS_STATE, self._on_state, STATE_QOS)
        self._diag = Diagnostics(self, 'forward kinematics', hardware_id=self.geometry.name)
        self.create_timer(0.5, self._report)
        self.add_post_set_parameters_callback(self._apply_parameters)

    def _apply_parameters(self, parameters) -> None:
        """The solver parameters take effect at run time (their ranges checked by declare_parameters)."""
        for p in parameters:
            if p.name in ('tolerance', 'max_iterations', 'max_jump', 'continuation_steps'):
                setattr(self.tracker, p.name, p.value)

    @property
    def position(self):
        return self.tracker.position

    @property
    def quaternion_xyzw(self):
        return self.tracker.quaternion_xyzw

    def _report(self) -> None:
        level, message = self._status
        values = {'solved': self.solved, 'failed': self.failed, **self._last}
        if level == OK:
            ik = inverse_kinematics(self.geometry, self.position, self.quaternion_xyzw)
            values['inverse_condition'] = float(inverse_condition_number(self.geometry, ik))
        self._diag.report(level, message, FkStatus(**values))

    def _fail(self, reason: str, level=ERROR) -> None:
        self.failed += 1
        self._status = (level, f'keeping the last good estimate: {reason}')
        self.get_logger().warning(self._status[1], throttle_duration_sec=1.0)
        self._report()

    def _on_state(self, msg: JointState) -> None:
        try:
            lengths = lengths_from_joint_state(msg)
        except ValueError as exc:
            self._fail(f'invalid actuators/state: {exc}', level=WARN)
            return
        if self._pose_msg is not None and np.array_equal(lengths, self._solved_lengths):
            self.solved += 1
            self._pose_msg.header.stamp = msg.header.stamp
            self._pub.publish(self._pose_msg)
            return
        update = self.tracker.update(lengths)
        fk = update.fk
        self._last = {'converged': bool(fk.converged), 'iterations': int(fk.iterations),
                      'residual': float(fk.residual), 'singular': bool(fk.singular),
                      'continuation': bool(update.continuation)}
        if not update.accepted:
            self._solved_lengths = self._pose_msg = None
            self._fail(update.reason)
            return
        self.solved += 1
        self._solved_lengths = lengths
        self._pose_msg = pose_to_msg(fk.position, fk.quaternion_xyzw, frame_id=self.frame_id,
                                     stamp=msg.header.stamp)
        self._pub.publish(self._pose_msg)
        if self._status[0] != OK:
            self._status = (OK, 'tracking actuators/state')
            self._report()


def main(args=None) -> None:
    run_nodes([FkNode], args)


if __name__ == '__main__':
    main()
