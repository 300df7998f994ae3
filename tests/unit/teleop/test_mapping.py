"""The teleop mapping (rrps_teleop.mapping): scale, clutch, deadman, guards, joint-space mode."""


import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rrps_description.geometry import load_robot
from rrps_description.rotations import quat_multiply_xyzw, rotation_angle_between, rotation_vector_to_quat_xyzw
from rrps_interfaces.teleop import DISENGAGED_CODES, TeleopCode
from rrps_kinematics import check_pose, inverse_kinematics, margins
from rrps_kinematics.backend import use_numba
from rrps_teleop.mapping import TeleopConfig, TeleopMapping
from rrps_teleop.master import MasterModel, scripted_pose
from rrps_testing.ci import require
from rrps_testing.reference_limits import reference_margins

SLAVE = load_robot('pole_climber')
MASTER = load_robot('master_robot')
DT = 0.01
#: The guards' kernels (rrps_teleop.compiled_guards) compiled and interpreted.
GUARDS = pytest.mark.parametrize('backend', (['numba'] if use_numba('auto') else []) + ['numpy'])


def rotated(q, rotation_vector):
    return quat_multiply_xyzw(rotation_vector_to_quat_xyzw(np.asarray(rotation_vector, float)), q)


class Session:
    """A mapping fed at 100 Hz by a MasterModel; the slave's FK pose is its last command (ideal slave)."""

    def __init__(self, config=None, slave_position=None, slave_quaternion=None, slave=SLAVE, backend='auto'):
        self.mapping = TeleopMapping(slave, config or TeleopConfig(), backend=backend)
        self.master = MasterModel(MASTER, max_linear_speed=1.0, max_angular_speed=10.0)
        self.t = 0.0
        self.slave_position = SLAVE.home_position if slave_position is None else np.asarray(slave_position)
        self.slave_quaternion = SLAVE.home_quaternion_xyzw if slave_quaternion is None else slave_quaternion
        self.mapping.on_slave_pose(self.slave_position, self.slave_quaternion)
        self.enable = True
        self.master_alive = True

    def tick(self, target=None):
        """Advance 10 ms: move the master towards ``target`` (pose), publish samples, step."""
        self.t += DT
        if target is not None:
            self.master.move_toward(*target, DT)
        if self.enable is not None:
            self.mapping.on_enable(self.t, self.enable)
        if self.master_alive:
            self.mapping.on_master_pose(self.t, self.master.position, self.master.quaternion_xyzw)
            self.mapping.on_master_lengths(self.t, self.master.lengths)
        out = self.mapping.step(self.t)
        if out.has_command:
            self.slave_position, self.slave_quaternion = out.position, out.quaternion_xyzw
            self.mapping.on_slave_pose(out.position, out.quaternion_xyzw)
        return out

    def run(self, seconds, target_of_t=None):
        outs = []
        for _ in range(int(round(seconds / DT))):
            target = None if target_of_t is None else target_of_t(self.t + DT)
            outs.append(self.tick(target))
        return outs


def lissajous(t, amplitude=0.004, period=10.0, angular_amplitude=0.04):
    return scripted_pose('lissajous', t, MASTER.home_position, MASTER.home_quaternion_xyzw,
                         amplitude=amplitude, period=period, angular_amplitude=angular_amplitude)


def test_cartesian_follows_the_master_within_the_scale_and_its_relative_rotation():
    s = Session(TeleopConfig(translation_scale=4.0))
    first = s.tick()
    assert first.code == TeleopCode.NO_WARNING and first.engaged
    np.testing.assert_allclose(first.position, SLAVE.home_position)  # engaging is a clutch
    outs = s.run(4.0, lambda t: lissajous(t - 2 * DT))  # starts at home one tick after engage
    assert all(o.engaged and o.code == TeleopCode.NO_WARNING for o in outs)
    dm = s.master.position - MASTER.home_position
    assert np.linalg.norm(dm) > 2e-3
    np.testing.assert_allclose(s.slave_position - SLAVE.home_position, 4.0 * dm, atol=1e-12)
    # Relative rotation: the slave turned exactly as the master did since engage (both from home).
    assert rotation_angle_between(s.master.quaternion_xyzw, s.slave_quaternion) < 1e-9
    assert rotation_angle_between(MASTER.home_quaternion_xyzw, s.slave_quaternion) > 0.01


def test_relative_rotation_is_applied_in_ring_a_frame_from_a_rotated_slave():
    q_slave = rotated(SLAVE.home_quaternion_xyzw, [0.0, 0.0, 0.2])
    s = Session(TeleopConfig(), slave_quaternion=q_slave)
    s.tick()
    turn = [0.05, -0.03, 0.0]
    s.run(0.5, lambda t: (MASTER.home_position, rotated(MASTER.home_quaternion_xyzw, turn)))
    expected = rotated(q_slave, turn)
    assert rotation_angle_between(expected, s.slave_quaternion) < 1e-9
    np.testing.assert_allclose(s.slave_position, SLAVE.home_position, atol=1e-12)


def test_absolute_rotation_engages_only_when_aligned_then_copies_the_master_orientation():
    q_slave = rotated(SLAVE.home_quaternion_xyzw, [0.0, 0.0, 0.3])
    s = Session(TeleopConfig(rotation_mode='absolute'), slave_quaternion=q_slave)
    out = s.tick()
    assert out.code == TeleopCode.ORIENTATION_MISMATCH and not out.has_command
    assert '0.300 rad' in out.detail
    # The operator aligns the master; engaging then happens with no jump.
    s.run(1.0, lambda t: (MASTER.home_position, rotated(MASTER.home_quaternion_xyzw, [0.0, 0.0, 0.26])))
    assert s.mapping.engaged
    s.run(0.5, lambda t: (MASTER.home_position, rotated(MASTER.home_quaternion_xyzw, [0.02, 0.0, 0.26])))
    assert rotation_angle_between(s.master.quaternion_xyzw, s.slave_quaternion) < 1e-9


def test_clutch_reengaging_never_jumps_and_indexes_the_master():
    s = Session()
    s.tick()
    def up(t):
        return (MASTER.home_position + [0.0, 0.0, 0.003], MASTER.home_quaternion_xyzw)
    s.run(1.0, up)
    held = s.slave_position.copy()
    np.testing.assert_allclose(held - SLAVE.home_position, [0.0, 0.0, 0.012], atol=1e-12)
    # Release the deadman, move the master back down (indexing), engage again.
    s.enable = False
    outs = s.run(1.0, lambda t: (MASTER.home_position, MASTER.home_quaternion_xyzw))
    assert all(o.code == TeleopCode.DEADMAN_RELEASED and not o.has_command for o in outs)
    s.enable = True
    out = s.tick()
    assert out.engaged
    np.testing.assert_allclose(out.position, held, atol=1e-15)  # no jump
    s.run(1.0, up)
    np.testing.assert_allclose(s.slave_position - held, [0.0, 0.0, 0.012], atol=1e-12)


def test_parameter_change_is_a_clutch():
    s = Session()
    s.tick()
    s.run(0.5, lambda t: (MASTER.home_position + [0.002, 0.0, 0.0], MASTER.home_quaternion_xyzw))
    held = s.slave_position.copy()
    s.mapping.configure(s.mapping.config.with_(translation_scale=2.0))
    assert not s.mapping.engaged
    out = s.tick()
    np.testing.assert_allclose(out.position, held, atol=1e-15)
    s.run(0.5, lambda t: (MASTER.home_position + [0.004, 0.0, 0.0], MASTER.home_quaternion_xyzw))
    np.testing.assert_allclose(s.slave_position - held, [0.004, 0.0, 0.0], atol=1e-12)


def test_deadman_lapse_holds_after_the_enable_timeout_and_ten_hertz_keeps_it():
    s = Session(TeleopConfig(enable_timeout=0.2))
    s.tick()
    # true at 10 Hz only: stays engaged.
    codes = []
    for k in range(50):
        s.enable = True if k % 10 == 0 else None
        codes.append(s.tick(lissajous(s.t + DT)).code)
    assert all(c not in DISENGAGED_CODES for c in codes)
    # No more true: engaged until 0.2 s after the last one, then hold.
    s.enable = None
    t_last = s.mapping.enable_time
    outs = s.run(0.4, lissajous)
    times = s.t - 0.4 + DT * np.arange(1, 41)
    for t, o in zip(times, outs):
        if abs(t - t_last - 0.2) > 1e-6:  # the step exactly at the timeout may go either way
            assert o.has_command == (t - t_last < 0.2), (t - t_last, o.code)
    assert outs[-1].code == TeleopCode.DEADMAN_RELEASED


def test_master_dropout_holds_after_the_master_timeout():
    s = Session(TeleopConfig(master_timeout=0.1))
    s.tick()
    s.run(0.5, lissajous)
    s.master_alive = False
    outs = s.run(0.3, lissajous)
    assert [o.has_command for o in outs[:9]] == [True] * 9  # master data younger than 0.1 s
    assert not any(o.has_command for o in outs[10:])  # (outs[9] is exactly at the timeout)
    assert outs[-1].code == TeleopCode.MASTER_STALE and 'master/pose' in outs[-1].detail


@pytest.mark.parametrize('mode', ['cartesian', 'joint'])
def test_a_master_sample_delivered_late_counts_from_when_it_was_taken(mode):
    # A transport stall delivers a sample 0.3 s after it was taken (its stamp): with
    # master_timeout 0.1 s it is stale on arrival, so it neither engages nor drives.
    m = TeleopMapping(SLAVE, TeleopConfig(mode=mode, master_timeout=0.1))
    m.on_slave_pose(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    m.on_enable(1.0, True)

    def receive(t, age):
        m.on_master_pose(t, MASTER.home_position, MASTER.home_quaternion_xyzw, stamp=t - age, age=age)
        m.on_master_lengths(t, MASTER.home_lengths, stamp=t - age, age=age)
    receive(1.0, 0.3)
    out = m.step(1.0)
    assert out.code == TeleopCode.MASTER_STALE and not out.has_command, out
    assert ' newer than 0.3 s ' in out.detail, out.detail
    receive(1.05, 0.05)  # on time: engaged, and the timeout runs from its stamp (1.0 s)
    assert m.step(1.05).has_command
    assert m.step(1.099).has_command and not m.step(1.101).has_command
    m.on_enable(1.2, True)
    receive(1.2, -0.5)  # stamped by a clock ahead of ours: as fresh as its receipt, no fresher
    assert m.step(1.25).has_command and not m.step(1.301).has_command


def test_a_hold_for_late_master_samples_says_they_came_late():
    m = TeleopMapping(SLAVE, TeleopConfig(master_timeout=0.1))
    m.on_slave_pose(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    m.on_enable(1.0, True)
    why = 'command is stale: 0.300 s old > timeout 0.100 s'
    m.on_master_late(1.0, why)  # dropped by the node: changes nothing but the reason
    out = m.step(1.0)
    assert out.code == TeleopCode.MASTER_STALE and not out.has_command
    assert out.detail == f'master/pose arrives too late: {why}'
    m.on_master_pose(1.05, MASTER.home_position, MASTER.home_quaternion_xyzw)
    assert m.step(1.05).has_command
    out = m.step(1.2)  # stale again, and the late sample is older than the last fresh one
    assert out.code == TeleopCode.MASTER_STALE and out.detail.startswith('no master/pose newer than 0.15'), out.detail


def test_no_engage_without_a_slave_pose_or_during_a_climb_step():
    m = TeleopMapping(SLAVE)
    m.on_enable(0.0, True)
    m.on_master_pose(0.0, MASTER.home_position, MASTER.home_quaternion_xyzw)
    assert m.step(0.01).code == TeleopCode.WAITING_FOR_SLAVE_POSE
    m.on_slave_pose(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    m.set_climb_executing(True)
    out = m.step(0.02)
    assert out.code == TeleopCode.CLIMB_EXECUTING and not out.has_command
    m.set_climb_executing(False)
    assert m.step(0.03).engaged
    m.set_climb_executing(True)  # a climb that starts anyway disengages teleop at once
    assert m.check(0.04)[0] == TeleopCode.CLIMB_EXECUTING and not m.engaged


@GUARDS
def test_guards_stop_an_unreachable_request_and_allow_moving_back(backend):
    s = Session(TeleopConfig(translation_scale=8.0, max_linear_speed=0.2), backend=backend)
    s.tick()
    def up(t):
        return (MASTER.home_position + [0.0, 0.0, 0.025], MASTER.home_quaternion_xyzw)
    outs = s.run(3.0, up)  # asks the slave for +0.2 m: beyond its 0.55 m stroke
    for o in outs:
        assert check_pose(SLAVE, o.position, o.quaternion_xyzw)[0]
    assert outs[-1].code == TeleopCode.JOINT_BOUND and 'stroke margin' in outs[-1].detail
    stuck = s.slave_position.copy()
    assert 0.0 <= outs[-1].margins['stroke'] < 0.2 * 0.01 + 1e-3
    # Moving back (down) is accepted at once.
    out = s.tick((MASTER.home_position, MASTER.home_quaternion_xyzw))
    assert out.code in (TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED)
    assert s.slave_position[2] < stuck[2]


@GUARDS
def test_a_slave_engaged_outside_its_limits_may_only_move_back_in(backend):
    outside = SLAVE.home_position + [0.0, 0.0, 0.16]
    assert not check_pose(SLAVE, outside, SLAVE.home_quaternion_xyzw)[0]
    s = Session(slave_position=outside, backend=backend)
    s.tick()
    out = s.tick((MASTER.home_position + [0.0, 0.0, 0.001], MASTER.home_quaternion_xyzw))
    assert out.code == TeleopCode.JOINT_BOUND
    np.testing.assert_allclose(s.slave_position, outside)
    out = s.tick((MASTER.home_position - [0.0, 0.0, 0.001], MASTER.home_quaternion_xyzw))
    assert out.code in (TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED)
    assert s.slave_position[2] < outside[2]


def inverse_condition(position, quaternion):
    return float(margins(SLAVE, inverse_kinematics(SLAVE, position, quaternion)).inverse_condition)


UP = np.array([0.0, 0.0, 1.0])  # raising ring_b lowers the conditioning of the pole climber here


@GUARDS
def test_singularity_band_slows_down_approaching_and_not_leaving(backend):
    home_c = inverse_condition(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    assert inverse_condition(SLAVE.home_position + 0.01 * UP, SLAVE.home_quaternion_xyzw) < home_c
    assert inverse_condition(SLAVE.home_position - 0.01 * UP, SLAVE.home_quaternion_xyzw) > home_c
    config = TeleopConfig(singularity_slowdown=2 * home_c, singularity_halt=0.0, max_linear_speed=0.05)
    s = Session(config, backend=backend)
    s.tick()
    out = s.tick((MASTER.home_position + 0.002 * UP, MASTER.home_quaternion_xyzw))
    assert out.code == TeleopCode.DECELERATE_FOR_APPROACHING_SINGULARITY
    step = np.linalg.norm(s.slave_position - SLAVE.home_position)
    assert 0.0 < step <= 0.5 * 0.05 * DT + 1e-12  # home is half-way through the band
    before = s.slave_position.copy()
    out = s.tick((MASTER.home_position - 0.002 * UP, MASTER.home_quaternion_xyzw))
    assert out.code == TeleopCode.SPEED_LIMITED  # leaving at full speed
    np.testing.assert_allclose(np.linalg.norm(s.slave_position - before), 0.05 * DT)


@GUARDS
def test_singularity_halt_threshold_stops_and_allows_moving_back(backend):
    home_c = inverse_condition(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    # A narrow band crossed in one 5 mm step: the step past the hard threshold is refused.
    halt = home_c - 2e-3
    config = TeleopConfig(singularity_slowdown=home_c - 1e-3, singularity_halt=halt, max_linear_speed=0.5)
    s = Session(config, slave=SLAVE.with_(max_speed=1.0), backend=backend)  # legs as fast as the Cartesian limit
    s.tick()
    outs = s.run(0.5, lambda t: (MASTER.home_position + 0.01 * UP, MASTER.home_quaternion_xyzw))
    assert TeleopCode.HALT_FOR_SINGULARITY in {o.code for o in outs}
    for o in outs:
        assert inverse_condition(o.position, o.quaternion_xyzw) >= halt
    assert s.slave_position[2] - SLAVE.home_position[2] < 0.02  # far short of the 0.04 m asked
    before = s.slave_position.copy()
    outs = s.run(0.05, lambda t: (MASTER.home_position - 0.01 * UP, MASTER.home_quaternion_xyzw))
    assert outs[-1].code in (TeleopCode.NO_WARNING, TeleopCode.SPEED_LIMITED)
    assert s.slave_position[2] < before[2] - 1e-3


@GUARDS
def test_collision_band_slows_down_approaching_interference(backend):
    # Twisted by 0.5 rad about z, legs 5 and 6 approach each other when twisting further.
    q_start = rotated(SLAVE.home_quaternion_xyzw, [0.0, 0.0, 0.5])
    s = Session(TeleopConfig(collision_slowdown=0.1, max_angular_speed=0.25), slave_quaternion=q_start, backend=backend)
    s.tick()
    out = s.tick((MASTER.home_position, rotated(MASTER.home_quaternion_xyzw, [0.0, 0.0, 0.01])))
    assert out.code == TeleopCode.DECELERATE_FOR_COLLISION
    assert rotation_angle_between(q_start, s.slave_quaternion) < 0.8 * 0.25 * DT
    before = s.slave_quaternion
    out = s.tick((MASTER.home_position, rotated(MASTER.home_quaternion_xyzw, [0.0, 0.0, -0.01])))
    assert out.code == TeleopCode.SPEED_LIMITED  # untwisting at full speed
    np.testing.assert_allclose(rotation_angle_between(before, s.slave_quaternion), 0.25 * DT)


@GUARDS
def test_speed_limits_bound_every_step(backend):
    s = Session(TeleopConfig(max_linear_speed=0.03, max_angular_speed=0.2), backend=backend)
    s.tick()
    far = (MASTER.home_position + [0.01, -0.01, 0.01], rotated(MASTER.home_quaternion_xyzw, [0.0, 0.3, 0.0]))
    prev_p, prev_q, prev_L = s.slave_position, s.slave_quaternion, SLAVE.home_lengths
    saw_limit = False
    for _ in range(100):
        out = s.tick(far)
        saw_limit |= out.code == TeleopCode.SPEED_LIMITED
        assert np.linalg.norm(out.position - prev_p) <= 0.03 * DT + 1e-12
        assert rotation_angle_between(prev_q, out.quaternion_xyzw) <= 0.2 * DT + 1e-9
        assert np.max(np.abs(out.lengths - prev_L)) <= SLAVE.max_speed * DT + 1e-9
        prev_p, prev_q, prev_L = out.position, out.quaternion_xyzw, out.lengths
    assert saw_limit


def test_joint_space_matches_cartesian_for_the_similar_master():
    """master_robot is pole_climber / 4: L_slave = 4 L_master is the Cartesian map with scale 4."""
    cart = Session(TeleopConfig(mode='cartesian', translation_scale=4.0))
    joint = Session(TeleopConfig(mode='joint', joint_scale=4.0))
    cart.tick(), joint.tick()
    for _ in range(300):
        target = lissajous(cart.t - DT)
        oc, oj = cart.tick(target), joint.tick(target)
        assert oc.code == oj.code == TeleopCode.NO_WARNING
        np.testing.assert_allclose(oj.lengths, oc.lengths, atol=1e-9)
    np.testing.assert_allclose(joint.slave_position, cart.slave_position, atol=1e-9)
    assert rotation_angle_between(joint.slave_quaternion, cart.slave_quaternion) < 1e-8
    np.testing.assert_allclose(joint.mapping.joint_offsets, 0.0, atol=1e-9)


def test_joint_space_offsets_are_calibrated_at_engage():
    start = SLAVE.home_position + [0.02, 0.0, -0.01]
    s = Session(TeleopConfig(mode='joint', joint_scale=4.0), slave_position=start)
    out = s.tick()
    L0 = inverse_kinematics(SLAVE, start, SLAVE.home_quaternion_xyzw).lengths
    np.testing.assert_allclose(out.lengths, L0, atol=1e-15)  # no jump
    s.run(0.5, lambda t: (MASTER.home_position + [0.0, 0.0, 0.001], MASTER.home_quaternion_xyzw))
    np.testing.assert_allclose(s.mapping.command.lengths - L0, 4.0 * (s.master.lengths - MASTER.home_lengths),
                               atol=1e-12)


def test_joint_mode_staleness_watches_the_master_lengths():
    m = TeleopMapping(SLAVE, TeleopConfig(mode='joint'))
    m.on_slave_pose(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
    m.on_enable(0.0, True)
    m.on_master_pose(0.0, MASTER.home_position, MASTER.home_quaternion_xyzw)
    out = m.step(0.01)
    assert out.code == TeleopCode.MASTER_STALE and 'master/actuators/state' in out.detail


@settings(max_examples=20, deadline=None)
@given(mode=st.sampled_from(['cartesian', 'joint']), scale=st.floats(0.5, 12.0),
       moves=st.lists(st.tuples(st.floats(-0.03, 0.03), st.floats(-0.03, 0.03), st.floats(-0.03, 0.03),
                                st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-0.5, 0.5),
                                st.booleans()),
                      min_size=1, max_size=5))
def test_property_commands_stay_within_limits_and_speed_and_clutch_never_jumps(mode, scale, moves):
    config = TeleopConfig(mode=mode, translation_scale=scale, joint_scale=scale,
                          max_linear_speed=0.1, max_angular_speed=0.5)
    s = Session(config)
    prev = None
    for x, y, z, rx, ry, rz, enable in moves:
        s.enable = enable
        target = (MASTER.home_position + [x, y, z], rotated(MASTER.home_quaternion_xyzw, [rx, ry, rz]))
        for _ in range(8):
            out = s.tick(target)
            if not out.has_command:
                assert out.code == TeleopCode.DEADMAN_RELEASED
                continue
            assert check_pose(SLAVE, out.position, out.quaternion_xyzw)[0]
            if prev is not None:  # the first command after a clutch is the slave's own pose
                assert np.max(np.abs(out.lengths - prev[2])) <= SLAVE.max_speed * DT + 1e-9
                if mode == 'cartesian':
                    assert np.linalg.norm(out.position - prev[0]) <= 0.1 * DT + 1e-12
                    assert rotation_angle_between(prev[1], out.quaternion_xyzw) <= 0.5 * DT + 1e-9
            prev = (out.position, out.quaternion_xyzw, out.lengths)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
                          st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)),
                min_size=1, max_size=30))
def test_property_joint_space_equals_cartesian_for_any_slow_master_path(steps):
    """Any master path slow enough for both speed limits gives the same leg lengths in both modes."""
    cart = Session(TeleopConfig(mode='cartesian', translation_scale=4.0))
    joint = Session(TeleopConfig(mode='joint', joint_scale=4.0))
    cart.tick(), joint.tick()
    p, q = MASTER.home_position.copy(), MASTER.home_quaternion_xyzw
    for dx, dy, dz, rx, ry, rz in steps:
        p = p + 5e-5 * np.array([dx, dy, dz])  # <= 0.9 mm/s per axis for the master
        q = rotated(q, 5e-4 * np.array([rx, ry, rz]))
        oc, oj = cart.tick((p, q)), joint.tick((p, q))
        assert oc.code == oj.code == TeleopCode.NO_WARNING
        np.testing.assert_allclose(oj.lengths, oc.lengths, atol=1e-9)


def test_samples_bunched_by_the_transport_keep_the_masters_time_budget():
    """Two master samples 10 ms apart that arrive together are not speed-limited: dt is the stamps' 10 ms."""
    for stamped in (True, False):
        m = TeleopMapping(SLAVE, TeleopConfig(max_linear_speed=0.05))
        m.on_slave_pose(SLAVE.home_position, SLAVE.home_quaternion_xyzw)
        m.on_enable(0.0, True)
        m.on_master_pose(0.0, MASTER.home_position, MASTER.home_quaternion_xyzw, stamp=0.0 if stamped else None)
        m.step(0.0)
        m.on_master_pose(0.0005, MASTER.home_position + [0.0001, 0.0, 0.0], MASTER.home_quaternion_xyzw,
                         stamp=0.01 if stamped else None)
        out = m.step(0.0005)  # 0.4 mm for the slave: 0.04 m/s over the 10 ms between the samples
        assert out.code == (TeleopCode.NO_WARNING if stamped else TeleopCode.SPEED_LIMITED)


@settings(max_examples=25, deadline=None)
@given(mode=st.sampled_from(['cartesian', 'joint']), scale=st.floats(0.5, 12.0),
       rotation=st.sampled_from(['relative', 'absolute']),
       moves=st.lists(st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05), st.floats(-0.05, 0.05),
                                st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)),
                      min_size=1, max_size=4))
@example(mode='cartesian', scale=1.0, rotation='relative',  # a master at exactly the angular limit
         moves=[(0.0, 0.0, 0.0, 0.0, 0.0, 0.0625), (0.0, 0.0, 0.03125, 0.0, 0.0, 0.0),
                (0.0, 0.0, -0.01171875, 0.0, -0.5, 0.5), (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)])
def test_property_compiled_guards_give_the_reference_commands_and_codes(mode, scale, rotation, moves):
    """The guarded step compiled and interpreted: the same code, detail and command at every step,
    on master paths that run into the speed limits, the strokes and the joint cones; each
    command's margins those of an independent computation."""
    require(use_numba('auto'), 'numba is not in use')
    config = TeleopConfig(mode=mode, translation_scale=scale, joint_scale=scale, rotation_mode=rotation,
                          max_linear_speed=2.0, max_angular_speed=10.0, collision_slowdown=0.02,
                          singularity_slowdown=0.05)
    fast = SLAVE.with_(max_speed=2.0)
    compiled, reference = Session(config, slave=fast, backend='numba'), Session(config, slave=fast, backend='numpy')
    for x, y, z, rx, ry, rz in moves:
        target = (MASTER.home_position + [x, y, z], rotated(MASTER.home_quaternion_xyzw, [rx, ry, rz]))
        for _ in range(10):
            a, b = compiled.tick(target), reference.tick(target)
            assert (a.code, a.engaged, a.has_command) == (b.code, b.engaged, b.has_command)
            assert a.detail.split(' margin ')[0] == b.detail.split(' margin ')[0]
            if a.has_command:
                np.testing.assert_allclose(a.command.buffer, b.command.buffer, rtol=1e-9, atol=1e-9)
                # the command's margins, independently (rrps_testing.reference_limits)
                ref, m = reference_margins(fast, a.command.position, a.command.quaternion), a.command.margins
                for name, atol in (('stroke', 1e-12), ('universal', 1e-7), ('spherical', 1e-7),
                                   ('interference', 1e-12)):
                    np.testing.assert_allclose(getattr(m, name), ref[name], atol=atol)
                assert m.inverse_condition == pytest.approx(ref['inverse_condition'], rel=1e-9)


@pytest.mark.parametrize('mode, rotation', [('cartesian', 'relative'), ('cartesian', 'absolute'),
                                            ('joint', 'relative')])
def test_the_warm_up_loads_every_guard_kernel_a_session_calls(mode, rotation):
    """A mapping loads its compiled guards when it is built, for the argument types of its
    steps: the first engaged step must not stall teleop_node's executor while numba loads or
    compiles (0.1-0.2 s, more than master_timeout: the slave would see its master go stale)."""
    require(use_numba('auto'), 'numba is not in use')
    from rrps_loads.compiled_statics import pose_statics
    from rrps_teleop import compiled_guards
    kernels = (compiled_guards.guarded_joint_step, compiled_guards.guarded_cartesian_step,
               compiled_guards.mapped_pose, compiled_guards.scaled_step, pose_statics)
    s = Session(TeleopConfig(mode=mode, rotation_mode=rotation, translation_scale=4.0, joint_scale=4.0))
    loaded = [len(k.signatures) for k in kernels]
    assert all(loaded)
    s.tick()
    for k in range(30):
        s.tick((MASTER.home_position + [0.0, 0.0, 2e-4 * k], MASTER.home_quaternion_xyzw))
    assert s.slave_position[2] > SLAVE.home_position[2] + 1e-3  # the session moved the slave
    assert [len(k.signatures) for k in kernels] == loaded, 'a kernel was compiled at a step'
