"""The climbing stack of the node tests: driver, IK, FK and climb node in the test's process,
sharing one executor, with the relaxed timing limits those tests need on a loaded machine.

The timing rules themselves are tested with their real limits elsewhere (docs/tests.md, 'Tests on a loaded
machine'); a test overrides any limit here.
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
