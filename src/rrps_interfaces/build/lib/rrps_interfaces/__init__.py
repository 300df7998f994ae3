"""The contracts between rrps nodes: topic and service names, enums and typed status values.

One module per node family (``kinematics``, ``driver``, ``teleop``, ``climb``, ``recording``)
on top of ``status`` (the typed status-value contract). Pure Python, no ROS import: the rosidl
interfaces of a C++ stack, for a Python one that uses only common_interfaces messages.
"""
