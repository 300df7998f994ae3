"""Node parameters: declared with a descriptor (description, range, read-only)."""

from __future__ import annotations

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.node import Node

from rrps_description.geometry import RobotGeometry, load_robot, shipped_robots

__all__ = ['declare_parameter', 'declare_robot_parameter']


def declare_parameter(node: Node, name: str, default, description: str, *,
                      min_value: float | None = None, max_value: float | None = None,
                      read_only: bool = False, additional_constraints: str = ''):
    """Declare a parameter with a descriptor (and a range for numbers); return its value."""
    descriptor = ParameterDescriptor(description=description, read_only=read_only,
                                     additional_constraints=additional_constraints)
    if isinstance(default, bool):
        descriptor.type = ParameterType.PARAMETER_BOOL
    elif isinstance(default, int) and min_value is not None and max_value is not None:
        descriptor.type = ParameterType.PARAMETER_INTEGER
        descriptor.integer_range = [IntegerRange(from_value=int(min_value), to_value=int(max_value),
                                                 step=0)]
    elif isinstance(default, float) and min_value is not None and max_value is not None:
        descriptor.type = ParameterType.PARAMETER_DOUBLE
        descriptor.floating_point_range = [FloatingPointRange(from_value=float(min_value),
                                                              to_value=float(max_value), step=0.0)]
    return node.declare_parameter(name, default, descriptor).value


def declare_robot_parameter(node: Node, name: str = 'robot', default: str = 'pole_climber',
                            description: str | None = None) -> RobotGeometry:
    """Declare the ``robot`` parameter (a shipped robot name or a YAML path) and load it.

    Raises RobotDescriptionError with the file and key when the description is invalid, so a
    node with a bad robot refuses to start with a clear message.
    """
    value = declare_parameter(
        node, name, default,
        description or f'shipped robot name ({", ".join(shipped_robots())}) or a robot YAML path',
        read_only=True)
    return load_robot(value)
