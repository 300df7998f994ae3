"""The hardware registry: implementations by name (the rrps.hardware and rrps.master_hardware
entry points), each owning its parameters, never one of its host's."""

from __future__ import annotations

import pytest

from rrps_hardware.registry import hardware_class, hardware_parameters, master_hardware_class, registered_hardware
from rrps_runtime.parameter_schema import NodeParameters, Parameter
from rrps_sim.simulated_robot import SimulatedRobot

HOST = NodeParameters('driver_node', 'rrps_hardware', [Parameter('rate', 500.0, 'the host\'s own')])


def test_the_installed_implementations_are_found_by_name():
    assert {'simulated', 'canopen'} <= set(registered_hardware())
    assert hardware_class('simulated') is SimulatedRobot
    assert master_hardware_class('canopen').__name__ == 'CanopenMaster'
    with pytest.raises(ValueError, match="unknown hardware 'x'; known: .*simulated"):
        hardware_class('x')


def test_an_implementation_owns_its_parameters_under_its_package():
    owned = hardware_parameters(HOST, SimulatedRobot)
    assert (owned.node, owned.package) == ('driver_node', 'rrps_sim')
    assert owned.parameters == SimulatedRobot.PARAMETERS and 'kp' in {p.name for p in owned}
    canopen = hardware_parameters(HOST, hardware_class('canopen'))
    assert (canopen.package, canopen.parameters) == ('rrps_canopen', ())


def test_an_implementation_may_not_declare_a_parameter_of_its_host():
    class Clashing(SimulatedRobot):
        PARAMETERS = (Parameter('rate', 1.0, 'taken by the host'),)

    with pytest.raises(ValueError, match='Clashing declares rate, parameters of driver_node itself'):
        hardware_parameters(HOST, Clashing)
