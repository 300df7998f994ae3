"""fk_node: actuators/state (measured leg lengths) -> pose (PoseStamped a_T_b, frame ring_a).

Newton-Raphson direct kinematics (paper section 2.2) seeded from the last estimate. An estimate
is accepted when it converged, its Jacobian is not singular, the sign of det(J) (which
separates assembly modes) is unchanged and it moved no more than ``max_jump`` (translation plus
rotation times the robot's characteristic length) from the last one (the first solve, seeded
from the home pose, is not checked for a jump). Otherwise the last good
estimate is kept, nothing is published and /diagnostics says why. Diagnostics carry converged,
iterations, residual and the inverse condition number of the last solve.

    fk_node --ros-args -r __ns:=/rrps -p robot:=pole_climber
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from ..forward import forward_kinematics
from ..inverse import inverse_kinematics
from ..jacobian import inverse_jacobian
from ..limits import inverse_condition_number
from ..rotations import quat_xyzw_to_matrix, rotation_angle_between
from .common import (ERROR, OK, STALE, STATE_QOS, WARN, Diagnostics, declare_parameter,
                     declare_robot_parameter, lengths_from_joint_state, pose_to_msg, run_nodes)

__all__ = ['FkNode', 'main']


class FkNode(Node):
    """Direct kinematics of the measured actuator lengths, warm-started."""

    def __init__(self, **kwargs):
        super().__init__('fk_node', **kwargs)
        g = self.geometry = declare_robot_parameter(self)
        self.frame_id = declare_parameter(self, 'frame_id', 'ring_a', 'frame_id of the published pose',
                                          read_only=True)
        self.tolerance = declare_parameter(self, 'tolerance', 1e-12,
                                           'Newton convergence: max leg-length residual [m]',
                                           min_value=1e-15, max_value=1e-3)
        self.max_iterations = declare_parameter(self, 'max_iterations', 30,
                                                'Newton iterations per solve', min_value=1, max_value=1000)
        self.max_jump = declare_parameter(
            self, 'max_jump', 0.05,
            'largest accepted change between estimates [m] (translation + rotation x characteristic '
            'length); 0 disables the check', min_value=0.0, max_value=10.0)
        self.position = np.array(g.home_position, dtype=float)
        self.quaternion_xyzw = np.array(g.home_quaternion_xyzw, dtype=float)
        self._rotation = quat_xyzw_to_matrix(self.quaternion_xyzw)
        self._det_sign = self._jacobian_sign(self.position, self.quaternion_xyzw)
        self.solved = 0
        self.failed = 0
        self._first = True
        self._last: dict = {}
        self._status = (STALE, 'waiting for actuators/state')
        self._pub = self.create_publisher(PoseStamped, 'pose', STATE_QOS)
        self.create_subscription(JointState, 'actuators/state', self._on_state, STATE_QOS)
        self._diag = Diagnostics(self, 'forward kinematics')
        self.create_timer(0.5, self._report)
        self.add_post_set_parameters_callback(self._apply_parameters)

    def _apply_parameters(self, parameters) -> None:
        """``tolerance``, ``max_iterations`` and ``max_jump`` take effect at run time."""
        for p in parameters:
            if p.name in ('tolerance', 'max_iterations', 'max_jump'):
                setattr(self, p.name, p.value)

    def _jacobian_sign(self, position, quaternion_xyzw) -> float:
        return float(np.sign(np.linalg.det(inverse_jacobian(
            inverse_kinematics(self.geometry, position, quaternion_xyzw)))))

    def _report(self) -> None:
        level, message = self._status
        values = {'solved': self.solved, 'failed': self.failed, **self._last}
        if level == OK:
            ik = inverse_kinematics(self.geometry, self.position, self.quaternion_xyzw)
            values['inverse_condition'] = float(inverse_condition_number(self.geometry, ik))
        self._diag.report(level, message, values)

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
        fk = forward_kinematics(self.geometry, lengths, self.position, self.quaternion_xyzw,
                                tolerance=self.tolerance, max_iterations=self.max_iterations)
        self._last = {'converged': fk.converged, 'iterations': fk.iterations,
                      'residual': fk.residual, 'singular': fk.singular}
        if not fk.converged or fk.singular:
            self._fail(f'no convergence (residual {fk.residual:.3g} m after {fk.iterations} '
                       f'iterations{", singular Jacobian" if fk.singular else ""})')
            return
        rotation = quat_xyzw_to_matrix(fk.quaternion_xyzw)
        jump = (float(np.linalg.norm(fk.position - self.position))
                + self.geometry.characteristic_length * float(rotation_angle_between(rotation, self._rotation)))
        if self.max_jump > 0.0 and jump > self.max_jump and not self._first:
            self._fail(f'estimate jumped {jump:.4f} m > max_jump {self.max_jump:.4f} m '
                       '(another assembly mode?)')
            return
        sign = self._jacobian_sign(fk.position, fk.quaternion_xyzw)
        if sign != self._det_sign:
            self._fail('det(J) changed sign: the solution crossed a singularity or switched '
                       'assembly mode')
            return
        self.position, self.quaternion_xyzw, self._rotation = fk.position, fk.quaternion_xyzw, rotation
        self.solved += 1
        self._first = False
        self._pub.publish(pose_to_msg(fk.position, fk.quaternion_xyzw, frame_id=self.frame_id,
                                      stamp=msg.header.stamp))
        if self._status[0] != OK:
            self._status = (OK, 'tracking actuators/state')
            self._report()


def main(args=None) -> None:
    run_nodes([FkNode], args)


if __name__ == '__main__':
    main()
