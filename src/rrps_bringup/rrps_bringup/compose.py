"""rrps-compose: several rrps nodes in one process and one executor, like a component container.

    rrps-compose ik_node fk_node climb_node --ros-args -r __ns:=/rrps -p robot:=pole_climber
    ros2 run rrps_teleop rrps-compose ik_node fk_node --ros-args -r __ns:=/rrps

Which nodes share a process is a deployment choice: the demo runs the robot computer's nodes
(IK, FK, climbing) in one such process, the simulated driver in another and the operator
station's nodes (master, teleop, viewer) in a third, so the 500 Hz state fan-out and the
viewer's web server never delay a command in the robot's executor. ``--ros-args`` apply to every
node of the process (use ``--params-file`` with node-named sections for per-node values).
"""

from __future__ import annotations

import importlib
import sys
from typing import Sequence

__all__ = ['NODES', 'node_class', 'main']

#: Every rrps node that can be composed: name -> 'module:Class'.
NODES = {
    'ik_node': 'rrps_kinematics.nodes.ik_node:IkNode',
    'fk_node': 'rrps_kinematics.nodes.fk_node:FkNode',
    'driver_node': 'rrps_sim.nodes.driver_node:DriverNode',
    'master_node': 'rrps_teleop.nodes.master_node:MasterNode',
    'teleop_node': 'rrps_teleop.nodes.teleop_node:TeleopNode',
    'climb_node': 'rrps_teleop.nodes.climb_node:ClimbNode',
    'viewer_node': 'rrps_teleop.nodes.viewer_node:ViewerNode',
    'recorder_node': 'rrps_recording.nodes.recorder_node:RecorderNode',
    'replay_node': 'rrps_recording.nodes.replay_node:ReplayNode',
    'markers_node': 'rrps_recording.nodes.markers_node:MarkersNode',
}


def node_class(name: str):
    """The node class registered as ``name``; ValueError naming the known ones."""
    if name not in NODES:
        raise ValueError(f'unknown node {name!r}; known: {", ".join(NODES)}')
    module, cls = NODES[name].split(':')
    return getattr(importlib.import_module(module), cls)


def main(argv: Sequence[str] | None = None) -> int:
    from rrps_runtime.process import run_nodes

    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    names, ros_args = argv[:split], argv[split:]
    if not names or any(n in ('-h', '--help') for n in names):
        print('usage: rrps-compose NODE [NODE ...] [--ros-args ...]\n'
              f'nodes: {", ".join(NODES)}', file=sys.stderr if not names else sys.stdout)
        return 2 if not names else 0
    if len(set(names)) != len(names):
        print(f'error: a node is named twice: {names}', file=sys.stderr)
        return 2
    try:
        classes = [node_class(name) for name in names]
    except ValueError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    run_nodes(classes, ['rrps-compose', *ros_args])
    return 0


if __name__ == '__main__':
    sys.exit(main())
