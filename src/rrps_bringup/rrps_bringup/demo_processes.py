"""The demo's child processes, as the system runs on a robot and an operator station (docs/deployment.md), each
started by ``rrps-compose`` (or the node's own module) with the priority its job asks for. A node's parameter file
comes first; the demo's settings and a scenario's ``parameters`` (node name -> {name: value}) win.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping

from rrps_bringup.scenarios import ros_arguments

__all__ = ['NAMESPACE', 'ROBOT_PROCESSES', 'ROBOT_NODES', 'OPERATOR_NODES', 'OBSERVER_NODES', 'driver_command',
           'start_driver', 'start_drives', 'start_robot_nodes', 'start_operator_nodes', 'start_recorder']

NAMESPACE = '/rrps'
#: The robot computer's nodes, in two processes: IK and FK, and the climbing node apart (its plans and previews run
#: in its worker process); the operator station's command path in another; the viewer in the demo's own process.
ROBOT_PROCESSES = {'robot kinematics': ('ik_node', 'fk_node'), 'robot climbing': ('climb_node',)}
ROBOT_NODES = ('ik_node', 'fk_node', 'climb_node')
OPERATOR_NODES = ('master_node', 'teleop_node')
#: The observers: the flight recorder and the robot's markers for RViz2 / Foxglove.
OBSERVER_NODES = ('recorder_node', 'markers_node', 'robot_description_node')


def _process_arguments(parameters: Mapping[str, Mapping], *nodes: str) -> list[str]:
    """``-p`` arguments of the nodes of one process (rcl gives them to each of its nodes)."""
    merged: dict = {}
    for node in nodes:
        merged.update(parameters.get(node, {}))
    return ros_arguments(merged)



def start_driver(*, robot: str, rate: float = 500.0, namespace: str = NAMESPACE,
                 state_file: str = '', activate: bool = False, hardware: str = 'simulated',
                 parameters: Mapping[str, Mapping] | None = None) -> subprocess.Popen:
    """The simulated hardware (driver_node) in a process of its own, as a real robot's driver: it claims its
    real-time priority itself, keeps the robot's state in ``state_file`` (a restart resumes it), starts inactive
    unless ``activate`` and dies with this process (stop it with :func:`rrps_runtime.supervision.stop_children`).
    """
    from rrps_runtime.supervision import CONTROL_NICE, start_child
    return start_child(driver_command(robot=robot, rate=rate, namespace=namespace, state_file=state_file,
                                      activate=activate, hardware=hardware, parameters=parameters),
                       nice=CONTROL_NICE)


def start_drives(*, robot: str) -> subprocess.Popen:
    """The simulated CANopen drives of ``robot``'s bus (``rrps-drive-sim``), above the driver's
    priority as real drives are hardware of their own; on the bus port of ``RRPS_CAN_PORT``."""
    from rrps_runtime.supervision import CONTROL_NICE, CONTROL_RT_PRIORITY, start_child
    return start_child([sys.executable, '-m', 'rrps_canopen_sim.process', '--robot', robot,
                        '--rt-priority', str(CONTROL_RT_PRIORITY + 10)], nice=CONTROL_NICE)


def driver_command(*, robot: str, rate: float = 500.0, namespace: str = NAMESPACE,
                   state_file: str = '', activate: bool = False, hardware: str = 'simulated',
                   parameters: Mapping[str, Mapping] | None = None) -> list[str]:
    """The command line of :func:`start_driver` (no state file: the parameter's default;
    ``parameters``: a scenario's, :func:`scenario_parameters`)."""
    from rrps_bringup.params import params_file_arguments
    return [sys.executable, '-m', 'rrps_hardware.nodes.driver_node', '--ros-args',
            *params_file_arguments('driver_node'), '-r', f'__ns:={namespace}',
            '-p', f'robot:={robot}', '-p', f'rate:={float(rate)}', '-p', f'hardware:={hardware}',
            *(['-p', f'state_file:={state_file}'] if state_file else []),
            '-p', f'auto_activate:={str(activate).lower()}',
            *_process_arguments(parameters or {}, 'driver_node')]


def start_robot_nodes(*, robot: str, namespace: str = NAMESPACE, nodes: tuple[str, ...] = ROBOT_NODES,
                      parameters: Mapping[str, Mapping] | None = None) -> subprocess.Popen:
    """Robot computer's ``nodes`` (default: all of them) composed in one process of their own
    (their command path claims its real-time priority itself)."""
    from rrps_bringup.params import params_file_arguments
    from rrps_runtime.supervision import CONTROL_NICE, start_child
    return start_child([sys.executable, '-m', 'rrps_bringup.compose', *nodes, '--ros-args',
                        *params_file_arguments(*nodes),
                        '-r', f'__ns:={namespace}', '-p', f'robot:={robot}',
                        *_process_arguments(parameters or {}, *nodes)], nice=CONTROL_NICE)


def start_operator_nodes(*, robot: str, namespace: str = NAMESPACE,
                         parameters: Mapping[str, Mapping] | None = None) -> subprocess.Popen:
    """The operator station's command path (:data:`OPERATOR_NODES`: master, teleop) composed in
    one process of their own, which claims its real-time priority itself."""
    from rrps_bringup.params import params_file_arguments
    from rrps_runtime.supervision import OPERATOR_NICE, start_child
    return start_child([sys.executable, '-m', 'rrps_bringup.compose', *OPERATOR_NODES, '--ros-args',
                        *params_file_arguments(*OPERATOR_NODES), '-r', f'__ns:={namespace}', '-p', f'robot:={robot}',
                        *_process_arguments(parameters or {}, *OPERATOR_NODES)], nice=OPERATOR_NICE)


def start_recorder(*, robot: str, output_dir: str, record: bool = False,
                   namespace: str = NAMESPACE, parameters: Mapping[str, Mapping] | None = None) -> subprocess.Popen:
    """The observers (:data:`OBSERVER_NODES`) in a process of their own, off the command path:
    the flight recorder (the last 60 s, written on a fault or on the viewer's "Save last 60 s";
    with ``record`` the whole session too), markers_node and robot_description_node."""
    from rrps_bringup.params import params_file_arguments
    from rrps_runtime.supervision import OBSERVER_NICE, start_child
    return start_child([sys.executable, '-m', 'rrps_bringup.compose', *OBSERVER_NODES,
                        '--ros-args', *params_file_arguments(*OBSERVER_NODES),
                        '-r', f'__ns:={namespace}', '-p', f'robot:={robot}',
                        '-p', f'output_dir:={output_dir}',
                        '-p', f'record:={"true" if record else "false"}',
                        *_process_arguments(parameters or {}, *OBSERVER_NODES)], nice=OBSERVER_NICE)
