"""The climbing stack of the node tests: driver, IK, FK and climb node in the test's process,
sharing one executor, with the limits those tests need to hold on a loaded machine.

The node tests run beside the system tests at nice 10 (tests/conftest.py): on a loaded CI
machine this process goes without the CPU for seconds. Measured in a fresh-clone CI run: for
14 s the driver received the IK's commands 0.16-1.13 s old, refused them as stale (timeout
0.1 s), and the climb node failed the step ("the pose did not arrive within 5.0 s"). These tests
check what a climb does; the timing rules themselves (stale commands, stale state, a pose that
never arrives) are tested on their own, with their real limits, in the driver's, IK's and climb
node's own tests and in the system tests. So this stack acts on commands up to
:data:`~rrps_testing.ros_harness.IN_PROCESS_COMMAND_TIMEOUT` old, pauses for state older than
:data:`STATE_TIMEOUT` or an operator station silent for :data:`OPERATOR_TIMEOUT` (a CI run paused
a step on inputs 0.51-0.57 s old), and waits :data:`SETTLE_TIMEOUT` for a pose or a gripper; a
test overrides any of them.
"""

from __future__ import annotations

from rrps_climbing.nodes.climb_node import ClimbNode
from rrps_hardware.nodes.driver_node import DriverNode
from rrps_kinematics.nodes.fk_node import FkNode
from rrps_kinematics.nodes.ik_node import IkNode
from rrps_testing.ros_harness import IN_PROCESS_COMMAND_TIMEOUT as COMMAND_TIMEOUT
from rrps_testing.ros_harness import params

__all__ = ['STATE_TIMEOUT', 'OPERATOR_TIMEOUT', 'SETTLE_TIMEOUT', 'climb_stack']

STATE_TIMEOUT = 1.0     # [s] the climb node's ``state_timeout``
OPERATOR_TIMEOUT = 1.0  # [s] the climb node's ``operator_timeout``
SETTLE_TIMEOUT = 30.0   # [s] the climb node's ``settle_timeout``


def climb_stack(ctx, robot: str = 'pole_climber', *, driver: dict | None = None,
                climb: dict | None = None) -> list:
    """[DriverNode, IkNode, FkNode, ClimbNode] of ``robot`` in context ``ctx``: the driver at
    200 Hz, activated at start; ``driver`` and ``climb`` override or add those nodes' parameters."""
    common = {'robot': robot}
    return [DriverNode(context=ctx, parameter_overrides=params(**(
                common | {'rate': 200.0, 'auto_activate': True, 'timeout': COMMAND_TIMEOUT} | (driver or {})))),
            IkNode(context=ctx, parameter_overrides=params(**common, timeout=COMMAND_TIMEOUT)),
            FkNode(context=ctx, parameter_overrides=params(**common)),
            ClimbNode(context=ctx, parameter_overrides=params(**(
                common | {'state_timeout': STATE_TIMEOUT, 'operator_timeout': OPERATOR_TIMEOUT,
                          'settle_timeout': SETTLE_TIMEOUT} | (climb or {}))))]
