"""The teleoperation mapping over ROS, launch-free: teleop_node with the master, IK, FK and driver
nodes follows the master within the scale, engages without a jump, maps leg lengths as it maps
poses, and takes parameter and mode changes at run time as a clutch.

Every node runs in-process under the namespace /rrps on a private domain id (ros_context). The
operator is a Probe: it holds the deadman (teleop/enable at 20 Hz), moves the master's handle,
or stands in for the master robot itself (publishing master/pose and master/actuators/state
sample by sample) where a test needs to control exactly which master sample produced a command.

Nothing here sleeps to let something happen: a test waits (ros_harness.wait_for, generous
deadline) for the observable result, e.g. the mapping's engagement on teleop/status, or so many
targets. Times are compared on one clock: the header stamps (when a node computed a message)
and the probe's receipt times on the ROS clock. The probe runs in the same executor as the nodes,
so its receipt of a message is, within milliseconds, the nodes' receipt of it; a guarantee such
as "holds within 0.1 s of the release" is measured from that receipt, so that transport delays
and stalls of a loaded machine do not count, only the nodes' own behaviour.

The tests of the mapping itself (its scale, clutch and joint map exactly, sample by sample) take
the guarded commands as they are (``jerk_limited`` false); the holds and refusals are in
test_teleop_holds.py.
"""

import time

import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter

from rrps_kinematics import inverse_kinematics
from rrps_runtime.messages import lengths_from_joint_state, pose_from_msg
from rrps_teleop.master import scripted_pose
from rrps_testing.ros_harness import DEADLINE, header_time, stamped_between, wait_for
from rrps_testing.teleop_rig import MASTER, NS, SLAVE, Rig

pytestmark = pytest.mark.ros


def target_position(item):
    return pose_from_msg(item[1])[0]


def stamp_of(item):
    return header_time(item)


def received_at(items, t):
    """Indices of the items (a probe's (receipt, msg) list) that a node in the probe's executor
    had last received at ``t`` [s, ROS clock]: the last one the probe received by then, or the
    next (a node's callback for a message may run just before the probe's)."""
    k = int(np.searchsorted([r for r, _ in items], t, 'right')) - 1
    return [i for i in (k, k + 1) if 0 <= i < len(items)]


def mapped_errors(targets, masters, k0=None, scale=4.0):
    """(errors, k0): |slave displacement - scale x master displacement| since the first target,
    for every later target, against the master sample it matches best among those stamped
    before it: exactly 0 for a target computed from a sample (message-triggered control),
    whichever sample it was. ``k0``: the index of the sample of the first target (the engage);
    None: the one (within 1 s of samples) that makes the most later targets exact.

    Which sample teleop_node had when it computed a target cannot be told from the messages
    behind a backlog of a loaded machine (samples wait in its queue); that it is the latest one,
    without a delay of its own, is checked sample by sample in _ping_pong_run."""
    m_stamps = np.array([stamp_of(m) for m in masters])
    m_pos = np.array([pose_from_msg(m[1])[0] for m in masters])
    t_pos = np.array([target_position(t) for t in targets])
    last = np.searchsorted(m_stamps, [stamp_of(t) for t in targets], 'right') - 1
    later = np.arange(len(m_pos))[None, :] > last[1:, None]  # samples stamped after each target
    moved = t_pos[1:] - t_pos[0]
    best = None
    for k in ([k0] if k0 is not None else range(max(last[0] - 100, 0), last[0] + 1)):
        distance = np.linalg.norm(moved[:, None, :] - scale * (m_pos[None, :, :] - m_pos[k]), axis=2)
        distance[later] = np.inf
        errors = distance.min(axis=1)
        if best is None or np.sum(errors < 1e-9) > np.sum(best[0] < 1e-9):
            best = errors, k
    return best


def limited_or_exact(targets, errors):
    """Whether every target after the first is exact (``errors`` < 1e-9) or else a step of at
    most the speed limit over the longest step time (0.05 m/s x 0.05 s) from the previous one:
    after a stall of a loaded machine the slave catches up, speed-limited."""
    steps = np.linalg.norm(np.diff([target_position(t) for t in targets], axis=0), axis=1)
    return bool(np.all((errors < 1e-9) | (steps <= 0.05 * 0.05 + 1e-9)))


def in_real_time(poses, since, rate, window=0.3):
    """Indices of the measured poses stamped after ``since`` whose driver ticks over the ``window``
    s before them all came within the driver's largest simulated step (5 periods at ``rate``) of
    each other: there the simulated slave kept up with real time. (A later tick simulates less
    time than passed: on a machine loaded beyond its cores the simulated slave falls behind real
    time, by design.)"""
    stamps = np.array([header_time(p) for p in poses])
    late = np.concatenate([[0], np.flatnonzero(np.diff(stamps) > 5.0 / rate) + 1])
    last_late = late[np.searchsorted(late, np.arange(len(stamps)), 'right') - 1]
    ok = (stamps > since) & (stamps - stamps[last_late] > window)
    return np.flatnonzero(ok)


def tracked(poses, commands, since, rate, window=0.3):
    """Indices of the measured poses stamped after ``since`` at which the simulation kept real
    time (:func:`in_real_time`) and so did the command path: every command the driver received
    in the ``window`` s before the pose came within two of their periods of its stamp. (On a
    machine whose cores other tests' real-time processes take, the in-process rig's commands
    arrive late and bunched; the slave follows them by their stamps, so it is then behind the
    newest one by what the stream moved meanwhile.)"""
    received = np.array([item[0] for item in commands])
    late = np.concatenate([[0], np.cumsum(received - np.array([header_time(item) for item in commands]) > 2.0 / rate)])
    indices = in_real_time(poses, since, rate)
    t = np.array([header_time(poses[i]) for i in indices])
    lo, hi = np.searchsorted(received, t - window, 'left'), np.searchsorted(received, t, 'right')
    return indices[(hi > lo) & (late[hi] == late[lo])]


def test_the_slave_follows_a_scripted_master_within_the_scale(ros_context):
    # 50 Hz master and driver: half the load of 100 Hz for the in-process simulation, which must
    # keep up with real time somewhere in the run for the tracking check below.
    rig = Rig(ros_context, master=dict(trajectory='lissajous', amplitude=0.004, period=8.0, rate=50.0),
              driver_rate=50.0, teleop=dict(jerk_limited=False))
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and len(rig.master_poses) > 10)
        rig.engage()
        n0, s0 = len(rig.targets), len(rig.status)
        engage = {}

        def progress():
            """(targets, exact ones, poses measured while the simulation and the command path kept
            real time)"""
            t = rig.targets[n0:]
            if len(t) < 30:
                return len(t), 0, 0
            errors, k0 = mapped_errors(t, list(rig.master_poses), engage.get('k0'))
            if np.sum(errors < 1e-9) >= 10:
                engage['k0'] = k0  # found: the engage's sample
            return (len(t), int(np.sum(errors < 1e-9)),
                    len(tracked(list(rig.poses), list(rig.commands), stamp_of(t[10]), rig.driver_rate)))

        def followed():
            """> 100 targets (one per master sample), > 5 mm of motion, 50 of them exact (after
            a stall of a loaded machine the slave catches up speed-limited for a while; starved
            of its core it may lag speed-limited most of the time) and 20 poses measured while
            the simulated slave and the command path kept up with real time."""
            t = rig.targets[n0:]
            if len(t) <= 100 or np.linalg.norm(target_position(t[-1]) - target_position(t[0])) <= 0.005:
                return False
            _, exact, real_time = progress()
            return exact >= 50 and real_time >= 20
        assert wait_for(followed, period=0.2), progress()
        targets = rig.targets[n0:]
        codes = {s.message for _, s in rig.status[s0:]}
        masters = list(rig.master_poses)
        commands = list(rig.commands)
        poses = list(rig.poses)
        # The master stops (its handle holds where it is): the slave must come to rest on the
        # last target.
        assert rig.master.set_parameters([Parameter('trajectory', value='none')])[0].successful
        rest = rig.wait_at_rest()
        final_target = rig.targets[-1]
    assert len(targets) > 100  # one target per master sample
    # A loaded machine may stall the executor beyond max_period: the slave then lags for a while.
    assert 'NO_WARNING' in codes and codes <= {'NO_WARNING', 'SPEED_LIMITED'}, codes
    moved = np.linalg.norm(target_position(targets[-1]) - target_position(targets[0]))
    assert moved > 0.005
    # Within the scale: the targets are exactly the mapping of a master sample (message-triggered
    # control; of the latest one: _ping_pong_run), 50 of them at least, and the others steps
    # within the speed limit. (The earlier bounds, 90 % exact and the rest within 2 mm of the
    # mapping, held for short stalls only: a 0.2 s stall costs 4 mm, caught up at 16 mm/s.)
    errors, _ = mapped_errors(targets, masters, engage['k0'])
    assert np.sum(errors < 1e-9) >= 50, (np.sum(errors < 1e-9), len(errors))
    assert limited_or_exact(targets, errors)
    # The measured slave pose (FK of the driver's lengths, stamped when the driver measured it)
    # tracks the target of the command the driver had last received then (commands carry their
    # target's stamp; the probe receives them in the driver's executor), wherever the simulation
    # kept up with real time. (Comparing the last pose with the last target after a fixed sleep
    # measured how far the pipeline had got in a wall-clock window: a loaded machine's backlog
    # made the slave look 20 mm behind.)
    by_stamp = {stamp_of(t): target_position(t) for t in targets}
    tracking = []
    for i in tracked(poses, commands, stamp_of(targets[10]), rig.driver_rate):
        pose = poses[i][1]
        errors = [np.linalg.norm(pose_from_msg(pose)[0] - by_stamp[stamp_of(commands[k])])
                  for k in received_at(commands, header_time(pose)) if stamp_of(commands[k]) in by_stamp]
        if errors:
            tracking.append(min(errors))
    assert len(tracking) >= 20 and np.median(tracking) < 3e-3, (len(tracking), np.median(tracking))
    # ... and comes to rest on the last target (the driver has no steady-state error).
    assert np.linalg.norm(pose_from_msg(rest[1])[0] - target_position(final_target)) < 1e-6


def test_clutch_causes_no_jump(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='circle', amplitude=0.004, period=4.0),
              teleop=dict(jerk_limited=False))
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses and len(rig.master_poses) > 10)
        rig.engage()
        rig.follow(50)
        t_switch = rig.probe.now()
        rig.enable = False
        assert wait_for(lambda: any(v['engaged'] == 'false' for _, _, v in rig.statuses_after(t_switch)))
        t_released = next(r for r, _, v in rig.statuses_after(t_switch) if v['engaged'] == 'false')
        m_released = pose_from_msg(rig.master_poses[-1][1])[0]
        # The master goes on a quarter turn (1 s of its samples: 5.7 mm, 23 mm for the slave).
        rig.wait_for_master_time(t_released + 1.0)
        # Disengaged: no target computed after the release was reported.
        assert not stamped_between(rig.targets, t_released), len(stamped_between(rig.targets, t_released))
        commanded = [target_position(t) for t in rig.targets]
        m_moved = np.linalg.norm(pose_from_msg(rig.master_poses[-1][1])[0] - m_released)
        measured = pose_from_msg(rig.wait_at_rest()[1])[0]  # the slave stands on its last target
        t_engage = rig.probe.now()
        rig.engage()

        def followed():  # 50 targets after the clutch, 30 of them exact
            after = [t for t in rig.targets if stamp_of(t) > t_engage]
            return len(after) >= 50 and np.sum(mapped_errors(after, list(rig.master_poses))[0] < 1e-9) >= 30
        assert wait_for(followed, period=0.2)
        targets = list(rig.targets)
        masters = list(rig.master_poses)
    assert 4.0 * m_moved > 0.005, m_moved  # a jump to the master's new place would show
    after = [t for t in targets if stamp_of(t) > t_engage]
    first = target_position(after[0])
    # The first target after the clutch is where the slave is: no jump.
    assert np.linalg.norm(first - measured) < 1e-6
    # While disengaged the slave held exactly where it was commanded: on one of the targets sent
    # before the release (the driver's lag has run out; it is the last one unless ik_node or the
    # driver refused the last ones as stale, which a loaded machine's backlog can cause, so the
    # last target itself is not the reference: the earlier check, within 2 mm of it, failed so).
    assert min(np.linalg.norm(np.array(commanded) - measured, axis=1)) < 1e-6
    # Never a jump: no step beyond the speed limit over the longest step time (0.05 m/s x 0.05 s).
    # (The probe records every target: a deep history, no sample lost to a stall.)
    # Within each engaged stream; across the clutch the step is from where the slave stands (above),
    # not from a last target that a loaded machine's driver may have refused as stale.
    before = [t for t in targets if stamp_of(t) <= t_engage]
    steps = [np.linalg.norm(target_position(b) - target_position(a))
             for stream in (before, after) for a, b in zip(stream, stream[1:])]
    assert max(steps) <= 0.05 * 0.05 + 1e-9, max(steps)
    # Re-indexed: from the clutch on, the slave follows the master's motion since the clutch (not
    # since the first engage: no catching up, even speed-limited, with the disengaged motion).
    # (Steps speed-limited after a stall of a loaded machine catch up; they are bounded above.)
    errors, _ = mapped_errors(after, masters)
    assert np.sum(errors < 1e-9) >= 30 and limited_or_exact(after, errors), (np.sum(errors < 1e-9), max(errors))


def _ping_pong_run(ros_context, mode):
    """The probe is the master: one sample, wait for teleop_node's output and the slave command,
    next. Returns (master L published, L of teleop_node's first output after each sample,
    commands L, status codes)."""
    rig = Rig(ros_context, teleop=dict(mode=mode, jerk_limited=False))
    outputs = rig.targets if mode == 'cartesian' else rig.commands  # teleop_node's own output

    def lengths(item):
        if mode == 'cartesian':
            return inverse_kinematics(SLAVE, *pose_from_msg(item[1])).lengths
        return lengths_from_joint_state(item[1])
    published, first = [], []
    with rig.spin(ros_context):
        assert wait_for(lambda: rig.poses)
        rig.enable = True
        # The deadman reached teleop_node: only the master's data is missing.
        assert wait_for(lambda: rig.code() == 'MASTER_STALE'), rig.code()
        for k in range(80):
            p, q = scripted_pose('lissajous', 0.01 * k, MASTER.home_position, MASTER.home_quaternion_xyzw,
                                 amplitude=0.004, period=8.0, angular_amplitude=0.04)
            n = len(outputs)
            published.append(rig.publish_master(p, q))
            previous = first[-1] if first else None

            def own_output():
                """teleop_node's first output after this sample that is not the previous sample's
                (a re-sent previous sample may still be answered after ``n``: same value)."""
                for item in list(outputs)[n:]:
                    value = lengths(item)
                    if previous is None or not np.allclose(value, previous, rtol=0.0, atol=1e-12):
                        return value
                return None
            assert wait_for(lambda: own_output() is not None), (mode, k)
            first.append(own_output())
            if mode == 'cartesian':
                n_commands, sent = len(rig.commands), [time.monotonic()]

                def resend():
                    """The same sample again after 0.5 s without ik_node's command (a stall may
                    have made the target stale on arrival: refused)."""
                    if time.monotonic() - sent[0] > 0.5:
                        rig.publish_master(p, q)
                        sent[0] = time.monotonic()
                    return False
                assert wait_for(lambda: len(rig.commands) > n_commands or resend()), (mode, k)
            # At least 10 ms between samples: the master's step (< 0.2 mm for the slave) stays
            # far below the speed limit over that time (0.5 mm); a loaded machine only adds time.
            time.sleep(0.01)
        commands = [lengths_from_joint_state(m) for _, m in rig.commands]
        codes = [(round(t, 3), s.message) for t, s in rig.status]
    return np.array(published), np.array(first), np.array(commands), codes


def test_joint_space_mode_matches_cartesian_mode_for_the_similar_master(ros_context):
    runs = {mode: _ping_pong_run(ros_context, mode) for mode in ('cartesian', 'joint')}
    for mode, (published, first, commands, codes) in runs.items():
        assert len(commands) > 60, mode
        assert not {c for _, c in codes} & {'SPEED_LIMITED', 'INVALID'}, (mode, codes)
        # Both follow L_slave = 4 L_master (master_robot = pole_climber / 4, engaged at home): the
        # joint map without FK, the Cartesian map through the master's FK, scale 4 and slave IK.
        # teleop_node's output after each sample is that of this very sample (message-triggered,
        # the latest sample, no delay of its own) ...
        late = np.abs(first - 4.0 * published).max(axis=1)
        assert late.max() < 1e-6, (mode, late.max(), np.flatnonzero(late >= 1e-6)[:5])
        # ... and every command is that of one master sample.
        errors = np.abs(commands[:, None, :] - 4.0 * published[None, :, :]).max(axis=2).min(axis=1)
        assert errors.max() < 1e-6, (mode, errors.max())
    moved = np.abs(runs['cartesian'][2][-1] - SLAVE.home_lengths).max()
    assert moved > 0.004


def test_parameters_are_validated_at_run_time_and_a_change_is_a_clutch(ros_context):
    rig = Rig(ros_context, master=dict(trajectory='none'))
    client = rig.probe.create_client(SetParameters, f'{NS}/teleop_node/set_parameters')

    def set_param(name, value, kind):
        field = {ParameterType.PARAMETER_DOUBLE: 'double_value',
                 ParameterType.PARAMETER_STRING: 'string_value'}[kind]
        request = SetParameters.Request(parameters=[ParameterMsg(
            name=name, value=ParameterValue(type=kind, **{field: value}))])
        future = client.call_async(request)
        assert wait_for(future.done)
        return future.result().results[0]

    with rig.spin(ros_context):
        assert client.wait_for_service(timeout_sec=DEADLINE)
        assert wait_for(lambda: rig.poses and rig.master_poses)
        rig.engage()
        for value in (0.0, -2.0, float('nan'), float('inf')):
            result = set_param('translation_scale', value, ParameterType.PARAMETER_DOUBLE)
            assert not result.successful, value
        result = set_param('mode', 'velocity', ParameterType.PARAMETER_STRING)
        assert not result.successful and 'mode must be one of' in result.reason
        result = set_param('translation_scale', 2.0, ParameterType.PARAMETER_DOUBLE)
        assert result.successful
        assert wait_for(lambda: rig.values()['scale'] == '2' and rig.values()['engaged'] == 'true')
        engaged_flags = [s[1].values for s in rig.status]
    assert rig.teleop.mapping.config.translation_scale == 2.0
    # The change released the clutch (engaged false) before engaging again.
    flags = [{kv.key: kv.value for kv in v}['engaged'] for v in engaged_flags]
    assert 'true' in flags and flags[-1] == 'true'
    assert any(a == 'true' and b == 'false' for a, b in zip(flags, flags[1:]))


def test_a_mode_change_swaps_the_master_input_and_teleop_goes_on(ros_context):
    """Switching modes while the master streams both inputs at 500 Hz: each switch is a clutch,
    the node takes the new mode's input only, and engages and follows again in each mode."""
    rig = Rig(ros_context, master=dict(trajectory='circle', rate=500.0))
    client = rig.probe.create_client(SetParameters, f'{NS}/teleop_node/set_parameters')

    def set_mode(mode):
        future = client.call_async(SetParameters.Request(parameters=[ParameterMsg(
            name='mode', value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=mode))]))
        assert wait_for(future.done)
        assert future.result().results[0].successful

    with rig.spin(ros_context):
        assert client.wait_for_service(timeout_sec=DEADLINE)
        assert wait_for(lambda: rig.poses and rig.master_poses)
        rig.engage()
        for mode in ('joint', 'cartesian') * 4:
            outputs = rig.commands if mode == 'joint' else rig.targets
            set_mode(mode)
            n = len(outputs)
            assert wait_for(lambda: rig.values()['mode'] == mode and rig.values()['engaged'] == 'true'
                            and len(outputs) > n + 10), (mode, rig.code())
            topic = rig.teleop._master_subscription.topic_name
            assert topic == f'{NS}/master/' + ('actuators/state' if mode == 'joint' else 'pose')
