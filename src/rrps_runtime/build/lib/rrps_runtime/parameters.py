"""Node parameters declared from the node's schema (:mod:`rrps_runtime.parameter_schema`):
descriptor, type, range, choices and read-only, all from the one declaration."""

from __future__ import annotations

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter

from rrps_runtime.parameter_schema import NodeParameters, Parameter

__all__ = ['descriptor', 'declare_parameters']

_TYPES = {bool: ParameterType.PARAMETER_BOOL, int: ParameterType.PARAMETER_INTEGER,
          float: ParameterType.PARAMETER_DOUBLE, str: ParameterType.PARAMETER_STRING}
_ARRAY_TYPES = {float: ParameterType.PARAMETER_DOUBLE_ARRAY, int: ParameterType.PARAMETER_INTEGER_ARRAY,
                str: ParameterType.PARAMETER_STRING_ARRAY}


def _ros_type(parameter: Parameter) -> int:
    """The rcl_interfaces ParameterType of ``parameter``."""
    return _ARRAY_TYPES[parameter.item_type] if parameter.type is tuple else _TYPES[parameter.type]


def descriptor(parameter: Parameter) -> ParameterDescriptor:
    """The ROS ParameterDescriptor of ``parameter``."""
    d = ParameterDescriptor(description=parameter.summary(), read_only=parameter.read_only,
                            type=_ros_type(parameter),
                            additional_constraints=parameter.constraints())
    if parameter.range is not None:
        lo, hi = parameter.range
        if parameter.type is int:
            d.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=0)]
        elif parameter.type is float:
            d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
    return d


def declare_parameters(node: Node, schema: NodeParameters) -> dict:
    """Declare every parameter of ``schema`` on ``node``; {name: value} (None when left unset).

    A value outside its range or choices raises ValueError naming it (the node does not
    start); while the node runs, a set request outside them is refused with the same reason.
    """
    values = {}
    for p in schema:
        if p.default is None:  # typed, unset unless given
            value = node.declare_parameter(p.name, RosParameter.Type(_ros_type(p)), descriptor(p)).value
        else:
            default = list(p.default) if p.type is tuple else p.default
            value = node.declare_parameter(p.name, default, descriptor(p)).value
        if p.type is tuple and value is not None:
            value = tuple(p.item_type(v) for v in value)
        if value is not None:
            p.check(value)
        values[p.name] = value

    def refuse_outside(changes) -> SetParametersResult:
        for change in changes:
            try:
                p = schema[change.name]
            except KeyError:
                continue
            try:
                p.check(tuple(change.value) if p.type is tuple else change.value)
            except (ValueError, TypeError) as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(refuse_outside)
    return values

