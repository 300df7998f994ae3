"""rrps-compose: several rrps nodes in one process and one executor, like a component container::

    rrps-compose ik_node fk_node --ros-args -r __ns:=/rrps -p robot:=pole_climber

``--ros-args`` apply to every node (per-node values: ``--params-file``); which nodes share a process:
docs/deployment.md."""

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
