"""The master robot on CANopen: master_node (``hardware: canopen``) reads the six leg encoders of
simulated drives and renders master/feedback as leg forces in cyclic synchronous torque mode,
bounded and passive, under a feedback wrench that steps and then oscillates. The forces and the
work they do on the operator's hand are measured on the drives' side (the simulator), not by the
code under test."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from rrps_description.geometry import load_robot
from rrps_interfaces.teleop import MASTER_FEEDBACK, MASTER_FRAME, MASTER_STATE
from rrps_testing.canopen_rig import DriveSim
from rrps_testing.ros_harness import Probe, Spinner, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.exclusive]  # the drive simulator and driver at SCHED_RR
MASTER = load_robot('master_robot')
NAMESPACE = '/rrps_master'


def wrench(probe, force, torque=(0.0, 0.0, 0.0)) -> WrenchStamped:
    msg = WrenchStamped()
    msg.header.frame_id = MASTER_FRAME
    msg.header.stamp = probe.get_clock().now().to_msg()
    (msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z) = force
    (msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z) = torque
    return msg


def bring_up(probe, states, attempts: int = 3) -> None:
    """Until the master publishes its encoders. Heartbeats or frames of the simulated drives lost
    at bring-up (on a loaded machine their one process can stall past the 0.1 s consumer time)
    latch a fault: the operator resets it (master_node/reset_faults), at most ``attempts`` times."""
    reset = probe.create_client(Trigger, 'master_node/reset_faults')
    for _ in range(attempts):
        if wait_for(lambda: len(states) > 10, timeout=10.0):
            return
        assert reset.wait_for_service(timeout_sec=10.0)
        answer = reset.call_async(Trigger.Request())
        assert wait_for(answer.done)
        print(f'\n  bring-up: master_node/reset_faults -> {answer.result().success}, '
              f'"{answer.result().message}"', flush=True)
        states.clear()
    assert wait_for(lambda: len(states) > 10)


def test_the_master_renders_the_feedback_bounded_and_passive(ros_context, monkeypatch):
    from rrps_teleop.nodes.master_node import MasterNode
    with DriveSim('master_robot', master=True) as sim:
        monkeypatch.setenv('RRPS_CAN_PORT', str(sim.port))
        node = MasterNode(context=ros_context, namespace=NAMESPACE, parameter_overrides=[
            Parameter('hardware', value='canopen'), Parameter('rate', value=200.0)])
        probe = Probe(context=ros_context, namespace=NAMESPACE)
        states = probe.collect(JointState, MASTER_STATE)
        feedback = probe.publisher(WrenchStamped, MASTER_FEEDBACK, command=True)
        with Spinner(ros_context, [node, probe]):
            bring_up(probe, states)
            drives = sim.status()['drives']
            assert {d['state'] for d in drives.values()} == {'operation_enabled'}
            assert {d['mode'] for d in drives.values()} == {10}
            np.testing.assert_allclose(states[-1].position, [d['position'] for d in drives.values()], atol=1e-6)
            work0 = np.array(sim.status()['work'])
            sim.ask(cmd='trace', on=True)
            t0 = time.monotonic()
            while (t := time.monotonic() - t0) < 4.0:
                if t < 1.5:
                    force = (0.0, 0.0, -4.0)                                      # a step
                else:
                    s = math.sin(2 * math.pi * 9.0 * t)                           # oscillating
                    force = (3.0 * s, -2.0 * s, 4.0 * math.sin(2 * math.pi * 5.0 * t))
                feedback.publish(wrench(probe, force, (0.05 * math.sin(2 * math.pi * 7.0 * t), 0.0, 0.0)))
                time.sleep(0.005)
            trace = sim.ask(cmd='trace', on=False)['trace']
            work = np.array(sim.status()['work']) - work0
            moved = np.ptp([row[2] for row in trace], axis=0)
    forces = np.array([row[3] for row in trace])
    limit = MASTER.bus.force_output.limit
    assert np.abs(forces).max() <= limit + 0.02, np.abs(forces).max()      # 0.02 N: one per mille of 20 N
    assert np.abs(forces).max() > 0.5, 'no force was rendered'
    assert moved.max() > 1e-5, 'the hand was never moved'
    period = 0.002
    one_period = limit ** 2 / 0.3 * period ** 2                             # what a period can let through
    assert work.max() <= 5 * one_period, (work, one_period)
