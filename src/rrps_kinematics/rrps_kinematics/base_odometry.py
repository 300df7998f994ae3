"""The robot's odometry as REP-105 states it: ``base_link`` (ring_a) in ``odom``, its twist, and
the covariance of both (nav_msgs/Odometry's content, without ROS).

World poses come from :class:`rrps_kinematics.odometry.RingOdometry`. First-order covariance from
independent leg-length noise σ: one FK pose has ``σ² (Jᵀ J)⁻¹`` (J the inverse Jacobian of eq. 1),
mapped onto base_link and summed over hand-overs (docs/recording.md, 'Markers and /tf').
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_description.rotations import quat_xyzw_to_rotation_vector, rotation_vector_to_matrix
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.jacobian import inverse_jacobian

__all__ = ['OdometryEstimate', 'BaseOdometry', 'fk_covariance']

#: A singular pose's FK tells nothing: its covariance, per coordinate [m², rad²].
UNKNOWN_VARIANCE = 1e6
_STEP = 1e-7  # the central differences' step [m, rad]


@dataclass(frozen=True)
class OdometryEstimate:
    """base_link in odom (``pose``, covariance 6x6 over x, y, z, rotation about x, y, z of odom),
    its ``twist`` (v [m/s], ω [rad/s] in base_link's frame) and the twist's 6x6 covariance."""

    pose: Pose
    pose_covariance: np.ndarray
    twist: np.ndarray
    twist_covariance: np.ndarray


def fk_covariance(geometry: RobotGeometry, a_T_b: Pose, length_stddev: float) -> np.ndarray:
    """Σ_FK = σ² (Jᵀ J)⁻¹: the 6x6 covariance of an FK pose's twist coordinates (v, ω of ring_b in
    ring_a's frame) from independent leg-length noise of standard deviation σ."""
    J = inverse_jacobian(inverse_kinematics(geometry, a_T_b.position, a_T_b.quaternion_xyzw))
    try:
        return length_stddev ** 2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return UNKNOWN_VARIANCE * np.eye(6)


def _perturbed(a_T_b: Pose, xi: np.ndarray) -> Pose:
    """a_T_b moved by the twist coordinates ``xi`` = (δp, δθ) in ring_a's frame."""
    return Pose.from_rotation(a_T_b.position + xi[:3], rotation_vector_to_matrix(xi[3:]) @ a_T_b.rotation)


def _base_map(world_T_b: Pose, a_T_b: Pose) -> np.ndarray:
    """d(base_link's pose in odom)/d(a_T_b's twist coordinates) of world_T_a = world_T_b · inv(a_T_b):
    rows x, y, z, rotation about odom's x, y, z; by central differences."""
    base = world_T_b @ a_T_b.inverse()
    G = np.zeros((6, 6))
    for k in range(6):
        xi = np.zeros(6)
        xi[k] = _STEP
        plus, minus = (world_T_b @ _perturbed(a_T_b, s * xi).inverse() for s in (1.0, -1.0))
        G[:3, k] = (plus.position - minus.position) / (2 * _STEP)
        G[3:, k] = (quat_xyzw_to_rotation_vector((plus @ base.inverse()).quaternion_xyzw)
                    - quat_xyzw_to_rotation_vector((minus @ base.inverse()).quaternion_xyzw)) / (2 * _STEP)
    return G


class BaseOdometry:
    """base_link's pose, twist and covariances from the chained world poses (module docstring).
    ``period`` [s]: the twist's interval before a second sample came."""

    def __init__(self, geometry: RobotGeometry, length_stddev: float, period: float):
        if not (np.isfinite(length_stddev) and length_stddev >= 0.0 and period > 0.0):
            raise ValueError('length_stddev must be >= 0 and period > 0')
        self.geometry = geometry
        self.length_stddev = float(length_stddev)
        self.period = float(period)
        self.frozen = np.zeros((6, 6))      # what earlier hand-overs froze into the pose
        self._release: np.ndarray | None = None  # the FK frozen when ring_a opened (ring_b grips alone)
        self._current = np.zeros((6, 6))
        self._last: tuple[Pose, float] | None = None

    def update(self, world_T_a: Pose, a_T_b: Pose, ring_a_grips: bool, t: float) -> OdometryEstimate:
        """The estimate at time ``t`` [s] of ring_a's world pose ``world_T_a``, with the measured
        ``a_T_b`` and whether ring_a's gripper is closed."""
        fk = fk_covariance(self.geometry, a_T_b, self.length_stddev)
        if ring_a_grips:
            if self._release is not None:   # ring_a closed again: the base stops where it is
                self.frozen = self.frozen + self._release + self._current
                self._release = None
            pose_covariance = self.frozen
        else:
            G = _base_map(world_T_a @ a_T_b, a_T_b)
            self._current = G @ fk @ G.T
            if self._release is None:       # ring_a opened: ring_b's pose froze this FK
                self._release = self._current
            pose_covariance = self.frozen + self._release + self._current
        dt = self.period
        twist = np.zeros(6)
        if self._last is not None and t > self._last[1]:
            dt = t - self._last[1]
            step = self._last[0].inverse() @ world_T_a
            twist = np.concatenate([step.position, quat_xyzw_to_rotation_vector(step.quaternion_xyzw)]) / dt
        self._last = (world_T_a, t)
        return OdometryEstimate(world_T_a, 0.5 * (pose_covariance + pose_covariance.T), twist,
                                2.0 * fk / dt ** 2)
