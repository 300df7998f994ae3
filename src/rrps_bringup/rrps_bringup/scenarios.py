"""Demo scenarios: a robot on its structure in the world, a payload, and what the operator does (docs/scenarios.md).

A scenario is one row of :data:`SCENARIOS`; :meth:`Scenario.parameters` gives every node the parameters it declares
(the driver's ``world_q_support`` and payload, the structure), so the driver, the climb node's odometry and the
viewer agree on where gravity points. Pure data and small helpers; no ROS import.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_description.geometry import load_robot
from rrps_description.rotations import matrix_to_quat_xyzw
from rrps_description.structures import Structure, make_structure
from rrps_description.world import STANDARD_GRAVITY, Support

__all__ = ['Scenario', 'SCENARIOS', 'scenario', 'ros_arguments']


@dataclass(frozen=True)
class Scenario:
    """One demo scenario (see the module docstring). ``handle_step`` [m], in a teleoperated one:
    the master handle's displacement in the master's ring_a frame (the robot's ring_b follows it,
    scaled, in ring_a's frame); ``motion``: that motion in words. ``payload_com`` in the ``payload_ring``'s frame [m].
    ``junction_deg`` > 0: the frame bent by that angle at its node, and the operator climbs one
    step across it (:meth:`crossing`) instead of teleoperating. ``node_parameters``: further
    (name, value) pairs for the nodes that declare them."""

    name: str
    robot: str
    structure: str
    summary: str
    motion: str
    handle_step: tuple[float, float, float] | None = None
    lean_deg: float = 0.0
    payload_mass: float = 0.0
    payload_ring: str = 'ring_b'
    payload_com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    junction_deg: float = 0.0
    node_parameters: tuple[tuple[str, object], ...] = ()

    def structure_model(self) -> Structure:
        if self.junction_deg > 0.0:
            return make_structure(self.structure, junction_deg=self.junction_deg)
        return make_structure(self.structure, lean_deg=self.lean_deg)

    def crossing(self) -> FrameNodePlanner:
        """The frame-node planner of the scenario's node (as the climb node builds it: the
        robot's own loads, the world's gravity); ValueError without ``junction_deg``."""
        if self.junction_deg <= 0.0:
            raise ValueError(f'scenario {self.name} crosses no frame node')
        return _frame_planner(self.robot, self.junction_deg)

    def support(self) -> Support:
        """ring_a gripping at the start: its attitude in the world is its gripper's grip frame
        on the structure (the extra ring DOF at zero: ring and gripper frames coincide); on a
        frame node, ring_a's at the crossing's start, on the searched beam face."""
        if self.junction_deg > 0.0:
            rotation = self.crossing().plan_crossing().phases[0].world_T_a.rotation
        else:
            _, rotation = self.structure_model().grip_frame(0.0)
        return Support.of('ring_a', matrix_to_quat_xyzw(rotation), STANDARD_GRAVITY)

    def gravity_in_g(self) -> np.ndarray:
        """Gravity in the supporting ring's frame, in units of g."""
        support = self.support()
        return support.gravity_in_support / np.linalg.norm(support.gravity)

    def world_parameters(self) -> dict[str, object]:
        """Every parameter the scenario sets, by name (each node takes those it declares)."""
        return {
            'robot': self.robot,
            'structure': self.structure,
            'structure_lean_deg': float(self.lean_deg),
            'world_q_support': tuple(float(v) for v in self.support().world_q_support),
            'payload_mass': float(self.payload_mass),
            'payload_ring': self.payload_ring,
            'payload_com': tuple(float(v) for v in self.payload_com),
            'junction_deg': float(self.junction_deg),
            **dict(self.node_parameters),
        }

    def parameters(self, node: str, schema) -> dict[str, object]:
        """The scenario's parameters that ``node``'s parameter ``schema`` (a NodeParameters)
        declares; nothing else (a node without the payload parameters does not get them)."""
        declared = {p.name for p in schema} if schema is not None else set()
        return {name: value for name, value in self.world_parameters().items() if name in declared}


#: The scenarios by name. A new one is a row here (its structure a name of
#: ``rrps_description.structures.STRUCTURES``).
SCENARIOS = {s.name: s for s in (
    Scenario('facade_wall', robot='facade_climber', structure='facade',
             summary='the facade climber on its vertical wall, 15 kg on ring_b',
             motion='ring_b out from the wall', handle_step=(0.0, 0.0, 0.004), payload_mass=15.0,
             node_parameters=(('start', 0.5),)),   # ring_a 0.5 m up the wall: ring_b's first move fits below
    Scenario('pole_leaning', robot='pole_climber', structure='pole', lean_deg=30.0,
             summary='the pole climber on a trunk leaning 30 deg, 40 kg on ring_b',
             motion='ring_b up the trunk', handle_step=(0.0, 0.0, 0.004), payload_mass=40.0),
    Scenario('frame_node', robot='frame_climber', structure='frame', junction_deg=90.0,
             summary='the frame climber across the node of a frame bent 90 deg, its own loads',
             motion='one climbing step up across the node'),
)}


@functools.cache
def _frame_planner(robot: str, junction_deg: float) -> FrameNodePlanner:
    return FrameNodePlanner(load_robot(robot), junction_deg)


def scenario(name: str) -> Scenario:
    """The scenario ``name``; ValueError naming the known ones."""
    if name not in SCENARIOS:
        raise ValueError(f'unknown scenario {name!r}: one of {", ".join(SCENARIOS)}')
    return SCENARIOS[name]


def _ros_value(value) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (tuple, list)):
        return '[' + ', '.join(_ros_value(v) for v in value) + ']'
    return str(value)


def ros_arguments(parameters: dict[str, object]) -> list[str]:
    """``-p name:=value`` pairs (after ``--ros-args``) of ``parameters``."""
    out: list[str] = []
    for name, value in parameters.items():
        out += ['-p', f'{name}:={_ros_value(value)}']
    return out
