"""Names of the robot's frames, joints and rings (REP-103 frames, SI units; docs/robot-model.md).

``WORLD_FRAME`` is the structure's fixed frame (z up); ``ODOM_FRAME``, REP-105's ``odom``, the one
in which the climb's odometry is continuous (no ``map``); ``BASE_FRAME``, ``base_link``, has ring_a."""

from __future__ import annotations

__all__ = ['WORLD_FRAME', 'ODOM_FRAME', 'BASE_FRAME', 'RING_A_FRAME', 'RING_B_FRAME', 'LEG_NAMES', 'RINGS',
           'ring_joint', 'prefixed']

RING_A_FRAME = 'ring_a'
RING_B_FRAME = 'ring_b'
WORLD_FRAME = 'world'
ODOM_FRAME = 'odom'
BASE_FRAME = 'base_link'

#: Joint names of the six legs, in leg order.
LEG_NAMES = tuple(f'leg_{i}' for i in range(1, 7))

#: The two rings, in the order of the grippers' state.
RINGS = ('ring_a', 'ring_b')


def ring_joint(ring: str) -> str:
    """Joint name of a ring's extra DOF (its angle about the ring axis, rad) in the actuator
    streams of robots that have one (paper section 3.1, Figure 9)."""
    if ring not in RINGS:
        raise ValueError(f"ring must be 'ring_a' or 'ring_b', got {ring!r}")
    return f'{ring}_rotation'


def prefixed(frame_prefix: str, frame: str) -> str:
    """A frame's name on /tf with a robot's ``frame_prefix`` (``robot_1/`` -> ``robot_1/odom``), as
    robot_state_publisher's ``frame_prefix`` names them: several robots in one domain."""
    return f'{frame_prefix}{frame}'
