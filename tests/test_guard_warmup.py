"""The IK node's compiled guard is warmed up for the argument types its targets have.

ik_node calls ``pose_limits`` with the robot's home pose at start-up so that the first target
does not wait for numba to compile (seconds on a busy machine, with the robot's executor
blocked). A robot's home quaternion is a read-only array, a target's is writable: numba types
them differently, so ``pose_limits`` must hand the kernel the same array type whatever it gets.
"""

from __future__ import annotations

import numpy as np
import pytest

from rrps_kinematics import load_robot
from rrps_kinematics.backend import use_numba
from rrps_kinematics.commands import pose_limits, validate_target


def test_the_warm_up_compiles_the_signature_targets_use():
    if not use_numba('auto'):
        pytest.skip('numba is not in use')
    from rrps_kinematics.compiled_limits import pose_margins
    g = load_robot('pole_climber')
    assert not g.home_quaternion_xyzw.flags.writeable  # the case this guards against
    pose_limits(g, g.home_position, g.home_quaternion_xyzw)       # ik_node's warm-up
    compiled = len(pose_margins.signatures)
    readonly = np.array([0.0, 0.0, 0.42])
    readonly.flags.writeable = False
    for p, q in (([0.0, 0.0, 0.42], [0.0, 0.0, 0.0, 1.0]),                  # lists
                 (np.array([0.0, 0.0, 0.42]), np.array([0.0, 0.0, 0.0, 1.0])),  # a target's arrays
                 (readonly, g.home_quaternion_xyzw)):
        validate_target(g, p, q, frame_id='ring_a')
        assert len(pose_margins.signatures) == compiled, 'a new compilation at the first target'
