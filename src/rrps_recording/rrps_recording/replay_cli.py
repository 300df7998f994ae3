"""rrps-replay: publish a recording again (``ros2 bag play`` for this stack).

    rrps-replay recordings/rrps_20250101_120000                   # a bag folder, 1x, then waits
    rrps-replay flight_..._operator --paused --start 30           # the viewer's timeline drives it

Runs :class:`rrps_recording.nodes.replay_node.ReplayNode`. The command streams go under ``<namespace>/replay/``
(a running driver never acts on a replay) unless ``--allow-commands`` (the robot will move)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

__all__ = ['main', 'parser']


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='rrps-replay',
        description='Replay a bag folder or MCAP recordings with their QoS at any rate, with pause and seek. '
                    'Command topics (target_pose, actuators/command, teleop/enable, '
                    'master/target_pose) are remapped under <namespace>/replay/ unless '
                    '--allow-commands: a replay never moves a live robot by default.')
    p.add_argument('files', nargs='+',
                   help='a bag folder (rrps-record, ros2 bag record -s mcap) or MCAP file(s) of one '
                        'recording')
    p.add_argument('--rate', type=float, default=1.0, help='speed (1.0 = as recorded)')
    p.add_argument('--start', type=float, default=0.0, help='start this far in [s]')
    p.add_argument('--paused', action='store_true', help='start paused')
    p.add_argument('--loop', action='store_true', help='start again at the end')
    p.add_argument('--exit-at-end', action='store_true', help='exit when the recording ends')
    p.add_argument('--topics', nargs='+', default=None, help='only these recorded topics')
    p.add_argument('--allow-commands', action='store_true',
                   help='publish the command topics on their live names (moves a live robot!)')
    p.add_argument('--namespace', default='/rrps',
                   help='namespace of the replay node, its replay/status and the remapped '
                        'command topics\' viewer (default /rrps; recorded topics keep their names)')
    p.add_argument('--clock', type=float, default=40.0, metavar='HZ',
                   help="publish /clock, the recording's time, at HZ (default 40, as ros2 bag play --clock; "
                        '0: none): nodes run with use_sim_time:=true follow the replay')
    p.add_argument('--remap-prefix', default='replay',
                   help='where the command topics go otherwise (default replay)')
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    args = parser().parse_args(argv[:split])
    from rrps_recording.storage.bag import is_bag
    missing = [f for f in args.files if not (Path(f).is_file() or is_bag(f))]
    if missing:
        print(f'error: no such file or bag folder: {", ".join(missing)}', file=sys.stderr)
        return 2
    if not 0.01 <= args.rate <= 100.0 or args.start < 0 or not 0.0 <= args.clock <= 1000.0:
        print('error: --rate must be 0.01..100, --start >= 0 and --clock 0..1000', file=sys.stderr)
        return 2
    files = ','.join(str(Path(f).resolve()) for f in args.files)
    ros = ['-r', f'__ns:={args.namespace}', '-p', f'files:=[{files}]', '-p', f'rate:={float(args.rate)}',
           '-p', f'start:={float(args.start)}',
           '-p', f'paused:={"true" if args.paused else "false"}',
           '-p', f'loop:={"true" if args.loop else "false"}',
           '-p', f'exit_at_end:={"true" if args.exit_at_end else "false"}',
           '-p', f'allow_commands:={"true" if args.allow_commands else "false"}',
           '-p', f'remap_prefix:={args.remap_prefix}', '-p', f'clock_rate:={float(args.clock)}']
    if args.topics:
        ros += ['-p', f'topics:=[{",".join(args.topics)}]']
    from rrps_recording.nodes.replay_node import ReplayNode
    from rrps_runtime.process import run_nodes
    run_nodes([ReplayNode], ['rrps-replay', '--ros-args', *ros, *argv[split + 1:]])
    return 0


if __name__ == '__main__':
    sys.exit(main())
