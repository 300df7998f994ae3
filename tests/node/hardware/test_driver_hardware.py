"""driver_node hosts whichever hardware its ``hardware`` parameter names: here an ideal robot
registered under another name, its own parameters (and none of the simulated robot's), its faults,
and an unknown name."""

from __future__ import annotations

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from lifecycle_msgs.msg import Transition as LifecycleTransition
from lifecycle_msgs.srv import ChangeState
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

import rrps_hardware.registry as hardware
from rrps_description.geometry import load_robot
from rrps_description.names import LEG_NAMES, RINGS
from rrps_hardware.interface import (
    OK,
    SUCCESS,
    ActuatorFault,
    ActuatorStatus,
    CallbackReturn,
    FaultKind,
    Result,
    ReturnType,
    SystemInterface,
    SystemState,
    Transition,
)
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_interfaces.driver import DriverStatus
from rrps_kinematics import inverse_kinematics
from rrps_runtime.parameter_schema import Parameter as SchemaParameter
from rrps_sim.simulated_robot import SimulatedRobot
from rrps_testing.node_helpers import command, said, statuses
from rrps_testing.ros_harness import DEADLINE, Probe, Spinner, wait_for

POLE = load_robot('pole_climber')

pytestmark = pytest.mark.ros


class IdealRobot(SystemInterface):
    """Legs that are where they were last commanded, no forces, grippers without interlock;
    ``fault`` (set by the test) latches until reset; ``settle``, a parameter of its own."""

    PARAMETERS = (SchemaParameter('settle', 0.0, 'a parameter of the ideal robot', unit='s', range=(0.0, 1.0)),)

    def __init__(self):
        self.lengths = np.zeros(6)
        self.closed = {ring: True for ring in RINGS}
        self.active = False
        self.fault: ActuatorFault | None = None

    def on_configure(self, config):
        self.parameters = dict(config.parameters)
        self.lengths = np.array(config.geometry.home_lengths, dtype=float)
        return SUCCESS

    def on_activate(self):
        if self.fault is not None:
            return Transition(CallbackReturn.FAILURE, f'{self.fault}: reset first')
        self.active = True
        return SUCCESS

    def on_deactivate(self):
        self.active = False
        return SUCCESS

    def on_cleanup(self):
        return SUCCESS

    def on_shutdown(self):
        return self.on_deactivate()

    def on_error(self):
        return self.on_deactivate()

    def write(self, time, period, command):
        if self.fault is not None:
            return Result(ReturnType.ERROR, str(self.fault))
        if command is not None and self.active:
            self.lengths = np.array(command.lengths, dtype=float)
        return OK

    def read(self, time, period):
        zeros = np.zeros(6)
        return SystemState(self.lengths.copy(), zeros, zeros, self.lengths.copy(), dict(self.closed), tuple(
            ActuatorStatus(name, self.active, True, True,
                           self.fault if self.fault is not None and self.fault.actuator == name else None)
            for name in LEG_NAMES))

    def hold(self):
        return OK

    def set_gripper(self, ring, close):
        if not self.active:
            return Result(ReturnType.ERROR, 'inactive')
        self.closed[ring] = close
        return OK

    def reset_faults(self):
        self.fault = None
        return OK


@pytest.fixture
def ideal_registered(monkeypatch):
    registered = hardware.registered_hardware()
    monkeypatch.setattr(hardware, 'registered_hardware', lambda: {**registered, 'ideal': lambda: IdealRobot})


def test_the_driver_hosts_a_hardware_registered_under_another_name(ros_context, ideal_registered):
    node = DriverNode(context=ros_context, namespace='/t', parameter_overrides=[
        Parameter('hardware', value='ideal'), Parameter('auto_activate', value=True), Parameter('settle', value=0.5)])
    assert isinstance(node.hardware, IdealRobot) and node.active
    # the driver declares this hardware's parameters and hands it their values; none of the simulated robot's
    assert node.get_parameter('settle').value == 0.5 and node.hardware.parameters == {'settle': 0.5}
    assert not any(node.has_parameter(p.name) for p in SimulatedRobot.PARAMETERS)
    probe = Probe(context=ros_context, namespace='/t')
    states = probe.collect(JointState, 'actuators/state')
    grippers = probe.collect(JointState, 'grippers/state')
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    pub = probe.publisher(JointState, 'actuators/command', command=True)
    gripper = probe.create_client(SetBool, 'grippers/ring_b/set')
    change_state = probe.create_client(ChangeState, 'driver_node/change_state')

    def activate() -> bool:
        future = change_state.call_async(ChangeState.Request(
            transition=LifecycleTransition(id=LifecycleTransition.TRANSITION_ACTIVATE)))
        assert wait_for(future.done)
        return future.result().success

    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.01], [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: states and pub.get_subscription_count() == 1)
        np.testing.assert_array_equal(states[-1].position, POLE.home_lengths)
        np.testing.assert_array_equal(states[-1].effort, np.zeros(6))  # the simulated robot holds its weight
        assert wait_for(lambda: (pub.publish(command(probe, goal)), node.accepted)[1], period=0.05)
        assert wait_for(lambda: np.array_equal(states[-1].position, goal))
        assert gripper.wait_for_service(timeout_sec=DEADLINE)
        future = gripper.call_async(SetBool.Request(data=False))
        assert wait_for(future.done) and future.result().success
        assert wait_for(lambda: list(grippers[-1].position) == [1.0, 0.0])

        def last_status() -> DriverStatus:
            return DriverStatus.from_key_values(statuses(diagnostics, 'driver_node')[-1].values)
        assert wait_for(lambda: statuses(diagnostics, 'driver_node') and not last_status().ring_b_closed)
        assert last_status().hardware == 'ideal' and last_status().faults == ()

        # a run-time parameter of the simulated robot is not this hardware's: not declared, refused
        assert not node.has_parameter('stuck_legs')
        with pytest.raises(ParameterNotDeclaredException):
            node.set_parameters([Parameter('stuck_legs', value=[2])])

        # a drive faults: the driver deactivates and says which; activation waits for a reset
        node.hardware.fault = ActuatorFault('leg_2', FaultKind.DRIVE_FAULT, 'over-current')
        assert wait_for(lambda: not node.active and said(diagnostics, 'driver_node', 'leg_2: drive_fault'))
        faulted = [s for s in statuses(diagnostics, 'driver_node') if 'leg_2' in s.message][-1]
        assert faulted.level == DiagnosticStatus.ERROR
        assert wait_for(lambda: last_status().faults == ('leg_2:drive_fault',))
        # commands that keep coming are counted as rejected; the fault's status stands (not flapping
        # with a rejection's at the command rate: an ERROR is logged each time it is set)
        seen, rejected = len(statuses(diagnostics, 'driver_node')), node.rejected
        assert wait_for(lambda: (pub.publish(command(probe, goal)), node.rejected >= rejected + 10)[1], period=0.01)
        assert not [s.message for s in statuses(diagnostics, 'driver_node')[seen:] if 'command rejected' in s.message]
        assert not activate() and not node.active
        node.hardware.reset_faults()
        assert activate() and node.active
    np.testing.assert_array_equal(node.reference, goal)


def test_an_unknown_hardware_is_refused_naming_the_known_ones(ros_context, ideal_registered):
    with pytest.raises(ValueError, match=r"unknown hardware 'cia402'; known: canopen, ideal, simulated"):
        DriverNode(context=ros_context, parameter_overrides=[Parameter('hardware', value='cia402')])


class OwnCycleRobot(IdealRobot):
    """An ideal robot whose setpoints a real-time cycle of its own steps (``OWN_CYCLE``, as a CANopen
    bus' SYNC): it records each write's period and command and reports that cycle's latency."""

    OWN_CYCLE = True

    def __init__(self):
        super().__init__()
        self.writes: list = []

    def write(self, time, period, command):
        self.writes.append((period, command))
        return super().write(time, period, command)

    def status_values(self):
        return {'target_latency_p50_ms': 0.5, 'target_latency_p99_ms': 1.5, 'target_latency_max_ms': 1.9}


def test_hardware_with_a_cycle_of_its_own_gets_each_command_as_it_arrives(ros_context, monkeypatch):
    """The driver writes a command to such hardware in the command's callback (period 0: not a
    tick of its own), and its status carries the hardware's latency to its cycle."""
    registered = hardware.registered_hardware()
    monkeypatch.setattr(hardware, 'registered_hardware', lambda: {**registered, 'own_cycle': lambda: OwnCycleRobot})
    node = DriverNode(context=ros_context, namespace='/t', parameter_overrides=[
        Parameter('hardware', value='own_cycle'), Parameter('auto_activate', value=True)])
    probe = Probe(context=ros_context, namespace='/t')
    diagnostics = probe.collect(DiagnosticArray, '/diagnostics')
    pub = probe.publisher(JointState, 'actuators/command', command=True)
    goal = inverse_kinematics(POLE, POLE.home_position + [0.0, 0.0, 0.01], [0, 0, 0, 1]).lengths
    with Spinner(ros_context, [node, probe]):
        assert wait_for(lambda: pub.get_subscription_count() == 1)
        assert wait_for(lambda: (pub.publish(command(probe, goal)), node.accepted)[1], period=0.05)
        handed = [c for period, c in list(node.hardware.writes) if period == 0.0 and c is not None]
        assert handed and np.array_equal(handed[0].lengths, goal)
        assert wait_for(lambda: statuses(diagnostics, 'driver_node') and DriverStatus.from_key_values(
            statuses(diagnostics, 'driver_node')[-1].values).target_latency_p99_ms == 1.5)
