"""The teleop mapping's validation (rrps_teleop.mapping): scales, parameters and malformed samples
are refused with a clear error and change nothing."""

import math

import pytest

from rrps_description.geometry import load_robot
from rrps_interfaces.teleop import TeleopCode
from rrps_teleop.mapping import TeleopConfig, TeleopMapping, validate_scale

SLAVE = load_robot('pole_climber')


@pytest.mark.parametrize('value', [0.0, -4.0, math.nan, math.inf, 'four', None])
def test_scale_validation(value):
    with pytest.raises(ValueError, match='translation_scale must be'):
        validate_scale(value)
    with pytest.raises(ValueError, match='translation_scale'):
        TeleopConfig(translation_scale=value)


@pytest.mark.parametrize('changes, match', [
    (dict(mode='velocity'), 'mode must be one of'),
    (dict(rotation_mode='euler'), 'rotation_mode must be one of'),
    (dict(joint_scale=(4.0, 4.0)), 'joint_scale must be a scalar or 6 values'),
    (dict(joint_scale=(4.0,) * 5 + (0.0,)), 'joint_scale must be finite and > 0'),
    (dict(enable_timeout=0.0), 'enable_timeout'),
    (dict(singularity_halt=0.5), 'singularity_halt must be in'),
])
def test_config_validation(changes, match):
    with pytest.raises(ValueError, match=match):
        TeleopConfig(**changes)


def test_malformed_samples_are_refused_and_change_nothing():
    m = TeleopMapping(SLAVE)
    with pytest.raises(ValueError, match='NaN'):
        m.on_master_pose(0.0, [0.0, math.inf, 0.0], [0, 0, 0, 1])
    with pytest.raises(ValueError, match='quaternion norm'):
        m.on_master_pose(0.0, [0.0, 0.0, 0.1], [0.5, 0, 0, 0.5])
    with pytest.raises(ValueError, match='master lengths'):
        m.on_master_lengths(0.0, [0.1] * 5)
    with pytest.raises(ValueError, match='slave pose'):
        m.on_slave_pose([0.0, 0.0, math.nan], [0, 0, 0, 1])
    m.on_enable(0.0, True)
    m.on_slave_pose(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    assert m.step(0.01).code == TeleopCode.MASTER_STALE
