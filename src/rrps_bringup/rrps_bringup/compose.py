"""rrps-compose: several rrps nodes in one process and one executor, like a component container.

    rrps-compose ik_node fk_node --ros-args -r __ns:=/rrps -p robot:=pole_climber
    ros2 run rrps_bringup rrps-compose master_node teleop_node --ros-args -r __ns:=/rrps

Which nodes share a process is a deployment choice: the demo runs IK and FK in one such process,
the climbing node (whose step plans take tens of milliseconds of Python) in another, the
simulated driver in a third and the operator station's master and teleop in a fourth, so that
the 500 Hz state fan-out, a plan and the viewer's web server never delay a command in the
robot's executor. ``--ros-args`` apply to every node of the process (use ``--params-file`` with
node-named sections for per-node values).
"""

from __future__ import annotations

import sys
from typing import Sequence

__all__ = ['main']


def main(argv: Sequence[str] | None = None) -> int:
    from rrps_bringup.registry import node_class, registered_nodes
    from rrps_runtime.process import run_nodes

    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    names, ros_args = argv[:split], argv[split:]
    if not names or any(n in ('-h', '--help') for n in names):
        print('usage: rrps-compose NODE [NODE ...] [--ros-args ...]\n'
              f'nodes: {", ".join(registered_nodes())}', file=sys.stderr if not names else sys.stdout)
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
