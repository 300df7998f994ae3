"""Smoke test of the public Python API (docs/usage.md: Python API; the detailed suites live beside it)."""

import numpy as np

from rrps_description.geometry import RobotGeometry, load_robot
from rrps_kinematics import forward_kinematics, inverse_kinematics


def test_api_contract_round_trip():
    geom = load_robot('pole_climber')
    position = geom.home_position + np.array([0.01, -0.02, 0.03])
    quaternion = np.array([0.02, -0.01, 0.05, 1.0])
    quaternion /= np.linalg.norm(quaternion)
    ik = inverse_kinematics(geom, position, quaternion)
    assert ik.lengths.shape == (6,)
    fk = forward_kinematics(geom, ik.lengths, geom.home_position, geom.home_quaternion_xyzw)
    assert fk.converged
    np.testing.assert_allclose(fk.position, position, atol=1e-10)
    assert abs(abs(np.dot(fk.quaternion_xyzw, quaternion)) - 1.0) < 1e-12
    custom = RobotGeometry(ring_a_anchors=geom.ring_a_anchors, ring_b_anchors=geom.ring_b_anchors)
    assert inverse_kinematics(custom, position[None], quaternion[None]).lengths.shape == (1, 6)
