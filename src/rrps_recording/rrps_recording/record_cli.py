"""rrps-record: record the rrps topics to a bag folder (``ros2 bag record -s mcap`` for this stack).

    rrps-record -o session                          # every topic under /rrps, /diagnostics, /tf, /tf_static
    rrps-record --flight-recorder-only -o faults    # only fault dumps, in faults/

Runs :class:`rrps_recording.nodes.recorder_node.RecorderNode`; ``-o NAME`` names the bag folder, which must not
exist (the flight recorder's dumps go beside it). Options and layout: docs/recording.md, 'Recording'.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Sequence

__all__ = ['main', 'parser']


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='rrps-record',
        description='Record every rrps topic, /diagnostics, /tf and /tf_static to a rosbag2 bag folder '
                    '(metadata.yaml and MCAP files: CDR messages, ros2msg schemas, offered QoS), '
                    'with a flight recorder that writes the last seconds when a fault is reported.')
    p.add_argument('-o', '--output', default='',
                   help='the bag folder, which must not exist (as ros2 bag record -o; default '
                        "rrps_<date>_<time>); with --flight-recorder-only the folder of the dumps")
    p.add_argument('--namespace', default='/rrps', help="the stack's namespace (default /rrps)")
    p.add_argument('--topics', nargs='+', default=None,
                   help='topics or prefixes to record (default: the namespace, /diagnostics, /tf, /tf_static)')
    p.add_argument('--max-size', type=float, default=0.0,
                   help='start a new file past this size [MiB] (0: no limit)')
    p.add_argument('--max-duration', type=float, default=0.0,
                   help='start a new file past this duration [s] (0: no limit)')
    p.add_argument('--compression', choices=('zstd', 'lz4', 'none'), default='zstd')
    p.add_argument('--buffer', type=float, default=60.0,
                   help='flight recorder window [s] (default 60)')
    p.add_argument('--flight-recorder-only', action='store_true',
                   help='write no continuous recording, only fault dumps and saves')
    p.add_argument('--no-flight-recorder', action='store_true', help='no flight recorder')
    p.add_argument('--robot', default='pole_climber',
                   help='robot of the /tf transforms (shipped name or YAML path)')
    return p


def ros_arguments(args: argparse.Namespace) -> list[str]:
    """The recorder_node parameters of the command-line options: the bag folder is ``prefix`` in
    ``output_dir`` (where the dumps go too), or the dumps' folder alone with --flight-recorder-only."""
    bag = Path(args.output)
    if args.flight_recorder_only:
        place = ['-p', f'output_dir:={args.output or "."}']
    else:
        place = ['-p', f'output_dir:={bag.parent}', '-p', f'prefix:={bag.name}']
    out = ['-r', f'__ns:={args.namespace}', *place,
           '-p', f'max_file_size_mb:={float(args.max_size)}',
           '-p', f'max_file_duration:={float(args.max_duration)}',
           '-p', f'compression:={args.compression}', '-p', f'buffer_seconds:={float(args.buffer)}',
           '-p', f'record:={"false" if args.flight_recorder_only else "true"}',
           '-p', f'flight_recorder:={"false" if args.no_flight_recorder else "true"}',
           '-p', f'robot:={args.robot}']
    if args.topics:
        out += ['-p', f'topics:=[{",".join(args.topics)}]']
    return out


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    args = parser().parse_args(argv[:split])
    if args.flight_recorder_only and args.no_flight_recorder:
        print('error: --flight-recorder-only and --no-flight-recorder leave nothing to do',
              file=sys.stderr)
        return 2
    if args.max_size < 0 or args.max_duration < 0 or args.buffer <= 0:
        print('error: --max-size and --max-duration must be >= 0, --buffer > 0', file=sys.stderr)
        return 2
    if not args.flight_recorder_only:
        args.output = args.output or time.strftime('rrps_%Y%m%d_%H%M%S')
        if Path(args.output).exists():
            print(f'error: the bag folder {args.output} exists (-o names a new one, as ros2 bag record -o)',
                  file=sys.stderr)
            return 2
    from rrps_recording.nodes.recorder_node import RecorderNode
    from rrps_runtime.process import run_nodes
    run_nodes([RecorderNode], ['rrps-record', '--ros-args', *ros_arguments(args),
                               *argv[split + 1:]])
    return 0


if __name__ == '__main__':
    sys.exit(main())
