"""driver_node in-process: kinematic and dynamic actuators, rejections, staleness, grippers, faults."""

import threading

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

import rrps_sim.hardware_state as hardware_state
from rrps_description.geometry import load_robot
from rrps_description.names import LEG_NAMES
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_interfaces.driver import DriverStatus
from rrps_kinematics import inverse_kinematics
from rrps_loads.statics import holding_forces
from rrps_sim.hardware_state import load_state
from rrps_testing.node_helpers import command, said, statuses
from rrps_testing.ros_harness import DEADLINE, Probe, Spinner, header_time, wait_for

POLE = load_robot('pole_climber')

pytestmark = pytest.mark.ros


def driver(ros_context, **overrides):
    overrides = {'auto_activate': True, **overrides}  # an active driver: commands move it
    return DriverNode(context=ros_context, namespace='/t',
                      parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])


def setup(ros_context, node):
    probe = Probe(context=ros_context, namespace='/t')
    return (probe, probe.collect(JointState, 'actuators/state'),
            probe.collect(DiagnosticArray, '/diagnostics'),
            probe.publisher(JointState, 'actuators/command', command=True))


def test_kinematic_actuators_track_within_the_speed_limit_and_reject_bad_commands(ros_context):
    node = driver(ros_context)
    probe, states, diagnostics, pub = setup(ros_context, node)
    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.005], [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: len(states) > 20 and pub.get_subscription_count() == 1)
        first = states[-1]
        assert list(first.name) == list(LEG_NAMES)
        # kinematic mode: effort = the quasi-static forces holding the home pose
        np.testing.assert_allclose(first.effort, holding_forces(POLE, POLE.home_position, [0, 0, 0, 1]),
                                   rtol=1e-6)
        np.testing.assert_allclose(first.position, POLE.home_lengths, atol=1e-12)
        # The state streams on the timer, not just on commands (none was sent): 100 more states,
        # at more than 20 Hz by their own stamps. Functional check only; the rate itself is
        # measured by benchmarks/viewer_load.py, not in a timed unit test.
        n0 = len(states)
        assert wait_for(lambda: len(states) > n0 + 100)
        stamps = [header_time(m) for m in states[n0:]]
        assert all(b > a for a, b in zip(stamps, stamps[1:]))
        assert (len(stamps) - 1) / (stamps[-1] - stamps[0]) > 20
        bad = [  # built when sent: each is fresh unless it is meant to be stale
            (lambda: command(probe, goal, age=0.5), 'stale'),
            (lambda: command(probe, goal + 0.2), 'outside the stroke'),
            (lambda: command(probe, [0.4] * 5 + [np.nan]), 'NaN'),
            (lambda: command(probe, [0.4] * 5, names=LEG_NAMES[:5]), 'missing joints'),
            (lambda: JointState(position=[0.4] * 7), 'expected 6 positions'),
        ]
        for make, text in bad:
            rejected, k = node.rejected, len(diagnostics)
            # Sent until the driver says why in a status after the first send: a command that a
            # stall delivered late is refused as stale before its stroke is checked.
            assert wait_for(lambda: (pub.publish(make()), node.rejected > rejected
                                     and said(diagnostics[k:], 'driver_node', text))[1], period=0.05), text
            np.testing.assert_allclose(node.reference, POLE.home_lengths, atol=1e-12)
        assert wait_for(lambda: (pub.publish(command(probe, goal)), node.accepted)[1])
        assert wait_for(lambda: np.allclose(states[-1].position, goal, rtol=0, atol=1e-9))
    velocities = np.array([m.velocity for m in states])
    assert np.max(np.abs(velocities)) <= POLE.max_speed + 1e-9
    # the jerk-limited setpoints: a rest-to-rest move of d at the jerk limit j, below the
    # acceleration limit, peaks at a = (d j^2 / 2)^(1/3) and at the speed a^2 / j (derived by hand)
    legs = POLE.motion_limits.legs
    d = np.abs(goal - POLE.home_lengths).max()
    peak = min((d * legs.jerk ** 2 / 2) ** (1 / 3), legs.acceleration) ** 2 / legs.jerk
    assert np.max(np.abs(velocities)) > 0.9 * peak


def test_hold_when_silent_stops_short_of_a_command_that_is_not_refreshed(ros_context):
    node = driver(ros_context, hold_when_silent=True, timeout=0.05)
    probe, states, diagnostics, pub = setup(ros_context, node)
    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.05], [0, 0, 0, 1]).lengths  # ~1 s away
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        assert wait_for(lambda: (pub.publish(command(probe, goal)), node.accepted)[1])
        assert wait_for(lambda: said(diagnostics, 'driver_node', 'holding'))
        # The first state stamped after the hold was reported, and 0.2 s of states after it.
        t_hold = probe.now()
        assert wait_for(lambda: header_time(states[-1]) > t_hold + 0.2)
        after = [np.array(m.position) for m in states if header_time(m) > t_hold]
        held = after[0]
        np.testing.assert_allclose(after, [held] * len(after), atol=1e-4)
    assert np.max(np.abs(held - POLE.home_lengths)) < 0.5 * np.max(np.abs(goal - POLE.home_lengths))


def test_gripper_services_enforce_the_interlock(ros_context):
    node = driver(ros_context)
    probe = Probe(context=ros_context, namespace='/t')
    grippers = probe.collect(JointState, 'grippers/state')
    clients = {ring: probe.create_client(SetBool, f'grippers/{ring}/set') for ring in ('ring_a', 'ring_b')}

    def call(ring, close):
        future = clients[ring].call_async(SetBool.Request(data=close))
        assert wait_for(future.done)
        return future.result()

    with Spinner(ros_context, [node, probe]):
        assert all(c.wait_for_service(timeout_sec=DEADLINE) for c in clients.values())
        assert wait_for(lambda: grippers)
        assert list(grippers[-1].name) == ['ring_a', 'ring_b'] and list(grippers[-1].position) == [1.0, 1.0]
        assert call('ring_b', False).success
        assert wait_for(lambda: list(grippers[-1].position) == [1.0, 0.0])
        refused = call('ring_a', False)
        assert not refused.success and 'ring_b is open' in refused.message
        assert list(grippers[-1].position) == [1.0, 0.0]
        assert call('ring_b', True).success
        refused = call('ring_a', False)   # ring_b takes its close time (the YAML's 0.8 s)
        assert not refused.success and 'ring_b is closing' in refused.message
        assert wait_for(lambda: list(grippers[-1].position) == [1.0, 1.0])
        assert call('ring_a', False).success
        assert wait_for(lambda: list(grippers[-1].position) == [0.0, 1.0])


def test_fault_injection_at_run_time(ros_context):
    node = driver(ros_context, time_constant=0.0, limit_speed=False)
    probe, states, diagnostics, pub = setup(ros_context, node)
    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.01], [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1 and states)
        assert not node.set_parameters([Parameter('stuck_legs', value=[7])])[0].successful
        assert node.set_parameters([Parameter('stuck_legs', value=[2, 5])])[0].successful
        assert wait_for(lambda: (pub.publish(command(probe, goal)), node.accepted)[1])
        moving = [0, 2, 3, 5]
        assert wait_for(lambda: np.allclose(np.array(states[-1].position)[moving], goal[moving], rtol=0, atol=1e-12))
        np.testing.assert_allclose(np.array(states[-1].position)[[1, 4]], POLE.home_lengths[[1, 4]], atol=1e-12)
        assert node.set_parameters([Parameter('sensor_noise', value=1e-3)])[0].successful
        n = len(states)
        assert wait_for(lambda: len(states) > n + 50)
        noise = np.array([m.position for m in states[n + 5:]]) - np.array(states[n + 5].position)
        assert 2e-4 < np.std(noise) < 5e-3
        assert node.set_parameters([Parameter('drop_probability', value=1.0)])[0].successful
        assert wait_for(lambda: node.dropped > 0)
        t_drop = probe.now()  # a tick has dropped its state: every later one drops it too
        assert wait_for(lambda: node.dropped > 50)  # the driver went on stepping, 50 ticks and more
        assert not [m for m in states if header_time(m) > t_drop]


def test_dynamic_mode_holds_and_tracks_with_effort_as_force(ros_context):
    node = driver(ros_context, mode='dynamic')
    probe, states, diagnostics, pub = setup(ros_context, node)
    p = POLE.home_position + [0.005, 0.0, 0.005]
    goal = inverse_kinematics(POLE, p, [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: len(states) > 100 and pub.get_subscription_count() == 1)
        np.testing.assert_allclose(states[-1].position, POLE.home_lengths, atol=1e-7)
        np.testing.assert_allclose(states[-1].effort, holding_forces(POLE, POLE.home_position, [0, 0, 0, 1]),
                                   rtol=1e-3)

        def stream():  # a 20 Hz stream, as a teleop would send
            pub.publish(command(probe, goal))
            return np.allclose(states[-1].position, goal, rtol=0, atol=1e-9)
        assert wait_for(stream, period=0.05)
    np.testing.assert_allclose(node.hardware.actuators.dynamics.position, p, atol=1e-7)
    assert np.max(np.abs([m.effort for m in states])) <= POLE.max_force


def test_frame_climber_ring_rotations(ros_context):
    frame = load_robot('frame_climber')
    node = DriverNode(context=ros_context, namespace='/t',
                      parameter_overrides=[Parameter('robot', value='frame_climber'),
                                           Parameter('auto_activate', value=True)])
    probe, states, diagnostics, pub = setup(ros_context, node)
    names = list(LEG_NAMES) + ['ring_b_rotation']
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1 and states)
        assert list(states[-1].name) == list(LEG_NAMES) + ['ring_a_rotation', 'ring_b_rotation']
        # Sent fresh until accepted: one message resent aged past the command timeout (a starved
        # process delivered it 0.104 s after its stamp) and every resend was older still.
        assert wait_for(lambda: (pub.publish(command(probe, list(frame.home_lengths) + [0.1], names=names)),
                                 node.accepted)[1], period=0.05)
        assert wait_for(lambda: abs(states[-1].position[7] - 0.1) < 1e-6)
        assert states[-1].position[6] == 0.0
        rejected = node.rejected
        # Sent (fresh) until refused for its ring rotation (a late one is refused as stale first).
        assert wait_for(lambda: (pub.publish(command(probe, list(frame.home_lengths) + [4.0], names=names)),
                                 node.rejected > rejected and said(diagnostics, 'driver_node', 'ring rotations'))[1],
                        period=0.05)


@pytest.mark.parametrize('overrides, message', [
    (dict(mode='fast'), 'mode must be one of'),
    (dict(initial_lengths=[0.4] * 5), 'initial_lengths must be 6'),
    (dict(initial_lengths=[0.2] * 6), 'outside the stroke'),
])
def test_invalid_parameters_refuse_to_start(ros_context, overrides, message):
    with pytest.raises(ValueError, match=message):
        driver(ros_context, **overrides)


def test_initial_lengths(ros_context):
    lengths = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.01, 0.0], [0, 0, 0, 1]).lengths
    node = driver(ros_context, initial_lengths=list(lengths))
    np.testing.assert_array_equal(node.state.positions, lengths)
    node.destroy_node()


def test_an_unstamped_command_is_not_acted_on(ros_context):
    node = driver(ros_context)
    probe, states, diagnostics, pub = setup(ros_context, node)
    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.005], [0, 0, 0, 1]).lengths
    unstamped = JointState(name=list(LEG_NAMES), position=[float(v) for v in goal])
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        assert wait_for(lambda: (pub.publish(unstamped), node.rejected)[1]
                        and said(diagnostics, 'driver_node', 'unstamped'))
        np.testing.assert_allclose(node.reference, POLE.home_lengths, atol=1e-12)
        assert node.accepted == 0


def test_a_blocked_state_file_never_holds_the_loop(ros_context, tmp_path, monkeypatch):
    """The state file is written by a thread of its own: while the file system blocks (a
    journal commit under load stopped a 100-byte write for 1 s on the CI machine), the driver
    still streams its state and follows commands; the file then holds where the robot is."""
    disk_back, writing = threading.Event(), threading.Event()
    save_state = hardware_state.save_state

    def blocked_save(path, state):
        writing.set()
        assert disk_back.wait(60.0)
        save_state(path, state)

    monkeypatch.setattr(hardware_state, 'save_state', blocked_save)
    path = tmp_path / 'robot.json'
    node = driver(ros_context, state_file=str(path))
    probe, states, diagnostics, pub = setup(ros_context, node)
    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.005], [0, 0, 0, 1]).lengths
    try:
        with Spinner(ros_context, [node, probe]):
            assert writing.wait(DEADLINE)  # the first write is stuck on the "disk"
            n0 = len(states)
            assert wait_for(lambda: (pub.publish(command(probe, goal)),
                                     len(states) > n0 + 50 and np.allclose(states[-1].position, goal,
                                                                           rtol=0, atol=1e-9))[1], period=0.05)
            assert not disk_back.is_set()  # all of that while the write was blocked
            disk_back.set()
            assert wait_for(lambda: load_state(path, POLE) is not None
                            and np.allclose(load_state(path, POLE).lengths, goal, rtol=0, atol=1e-6))
    finally:
        disk_back.set()
        node.destroy_node()


def test_a_state_file_that_cannot_be_written_is_reported(ros_context, tmp_path):
    not_a_dir = tmp_path / 'not_a_dir'
    not_a_dir.write_text('a file where the directory should be')
    node = driver(ros_context, state_file=str(not_a_dir / 'robot.json'))
    probe, states, diagnostics, pub = setup(ros_context, node)
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: said(diagnostics, 'driver_node', 'not written'))
        assert len(states) > 0 or wait_for(lambda: states)  # the loop runs on
    status = [s for s in statuses(diagnostics, 'driver_node') if 'not written' in s.message][-1]
    assert status.level == DiagnosticStatus.WARN
    assert str(not_a_dir) in DriverStatus.from_key_values(status.values).state_file_error
    node.destroy_node()


def test_a_sensor_data_reader_matches_the_reliable_state_stream(ros_context):
    """The 500 Hz actuators/state is offered reliable (docs/usage.md, the ROS interface: so that the
    stack's reliable readers and a ROS user's sensor-data reader both match it); a reader with
    rclpy's sensor-data profile (best effort, as RViz2 and PlotJuggler read sensors) gets it."""
    from rclpy.node import Node
    from rclpy.qos import ReliabilityPolicy, qos_profile_sensor_data
    node = driver(ros_context)
    reader = Node('sensor_data_reader', context=ros_context, namespace='/t')
    got = []
    reader.create_subscription(JointState, 'actuators/state', got.append, qos_profile_sensor_data)
    with Spinner(ros_context, [node, reader]):
        assert wait_for(lambda: len(got) > 20)
        offered = reader.get_publishers_info_by_topic('/t/actuators/state')
    assert [i.qos_profile.reliability for i in offered] == [ReliabilityPolicy.RELIABLE]
    assert list(got[-1].name) == list(LEG_NAMES) and len(got[-1].position) == 6
    reader.destroy_node()


def test_a_hardware_verb_that_raises_is_an_error_with_its_reason(ros_context, monkeypatch):
    """An exception out of the hardware's activation (a library error it did not expect) leaves the
    driver inactive, with the exception's text in the log and in its ERROR status: rclpy's
    lifecycle alone would turn it into an error state without a word."""
    from rrps_sim.simulated_robot import SimulatedRobot

    def raising(self):
        raise RuntimeError('the bus went away mid-homing')
    monkeypatch.setattr(SimulatedRobot, 'on_activate', raising)
    node = driver(ros_context)
    probe, _, diagnostics, pub = setup(ros_context, node)
    try:
        with Spinner(ros_context, [node, probe]):
            assert not node.active
            expected = 'on_activate failed: RuntimeError: the bus went away mid-homing'
            assert wait_for(lambda: any(s.level == DiagnosticStatus.ERROR and expected in s.message
                                        for s in statuses(diagnostics, 'driver_node'))), [
                s.message for s in statuses(diagnostics, 'driver_node')][-3:]
            pub.publish(command(probe, POLE.home_lengths))
            assert wait_for(lambda: node.rejected >= 1)   # nothing moves
    finally:
        node.destroy_node()
