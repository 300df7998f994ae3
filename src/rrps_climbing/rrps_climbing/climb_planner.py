"""The planner and configuration of a climb from climb_node's parameters, pure Python.

:func:`climb_planner` picks the gait, a frame node's crossing or a route; :func:`start_position`,
:func:`step_config` and :func:`preview_config` give the step machine's start and settings,
:func:`step_machine` the machine itself.
"""

from __future__ import annotations

from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.gait import GaitPlanner
from rrps_climbing.load_check import LoadCheck
from rrps_climbing.route import ROUTES
from rrps_climbing.route_steps import ROUTE_START, RouteSteps, route_planner
from rrps_climbing.step_io import StepConfig
from rrps_climbing.step_machine import ClimbStepMachine
from rrps_climbing.step_preview import PreviewConfig
from rrps_description.geometry import RobotGeometry
from rrps_description.structures import structure_from_parameters

__all__ = ['climb_planner', 'start_position', 'step_config', 'preview_config', 'step_machine']


def climb_planner(geometry: RobotGeometry, values: dict) -> GaitPlanner:
    """The inchworm gait on the structure, or with ``junction_deg`` the frame-node crossing
    (its search's refusal is kept in the planner's ``refusal``: every step then refuses it), or
    a route; ValueError for parameters that do not go together."""
    if values['structure'] in ROUTES:
        return route_planner(geometry, values['structure'], loads=LoadCheck(speed=values['speed'] or None),
                             corner_deg=values['corner_deg'], bends_deg=values['route_bends_deg'],
                             use_extra_dof=values['use_extra_dof'])
    if values['junction_deg'] <= 0.0:
        if values['out_of_plane']:
            raise ValueError('out_of_plane needs junction_deg > 0')
        structure = structure_from_parameters(values)
        return GaitPlanner(geometry, structure, use_extra_dof=values['use_extra_dof'],
                           loads=LoadCheck(speed=values['speed'] or None))
    if values['structure'] != 'frame':
        raise ValueError(f"junction_deg needs structure 'frame', got {values['structure']!r}")
    return FrameNodePlanner(geometry, values['junction_deg'], values['out_of_plane'],
                            use_extra_dof=values['use_extra_dof'])


def start_position(planner: GaitPlanner, values: dict) -> float | None:
    """Route position [m] of ring_a's gripper at start: the ``start`` parameter, else the
    searched stance before a frame node, the start of a route, or None (the lowest that fits)."""
    start = values['start'] if values['start'] >= 0.0 else None
    if isinstance(planner, FrameNodePlanner) and planner.crossing is not None and start is None:
        start = planner.crossing.candidate.s_pre
    if isinstance(planner, RouteSteps) and start is None:
        start = ROUTE_START
    return start


def step_config(values: dict) -> StepConfig:
    """The step machine's period, arrival tolerances, settling and input timeouts."""
    return StepConfig(period=1.0 / values['rate'],
                      **{k: values[k] for k in ('position_tolerance', 'orientation_tolerance',
                                                'settle_timeout', 'settle_time', 'state_timeout',
                                                'operator_timeout')})


def preview_config(values: dict) -> PreviewConfig:
    """How each step is previewed: the world's gravity [m/s²] and the smallest holding margin."""
    if len(values['gravity']) != 3:
        raise ValueError(f"gravity: expected 3 numbers [m/s^2], got {values['gravity']}")
    return PreviewConfig(gravity=tuple(values['gravity']), min_margin=values['preview_min_margin'])


def step_machine(planner: GaitPlanner, values: dict) -> ClimbStepMachine:
    """climb_node's step machine: ``planner``'s steps with the parameter ``values``."""
    return ClimbStepMachine(planner, step_config(values), start=start_position(planner, values),
                            step_length=values['step_length'] or None, auto_steps=values['auto_steps'],
                            preview=values['preview'])
