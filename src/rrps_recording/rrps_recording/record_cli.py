"""rrps-record: record the rrps topics to a bag folder (``ros2 bag record -s mcap`` for this stack).

    rrps-record -o recordings                       # every topic under /rrps, /diagnostics, /tf, /tf_static
    rrps-record -o recordings --max-size 500 --max-duration 600     # split files
    rrps-record -o recordings --flight-recorder-only                # only fault dumps
    rrps-record ... --ros-args -p buffer_seconds:=120.0             # any recorder_node parameter

Runs :class:`rrps_recording.nodes.recorder_node.RecorderNode` (its docstring says what is
recorded and how): the bag folder ``<output>/<prefix>/`` holds ``metadata.yaml`` and the MCAP
files. Ctrl-C closes the current file and completes ``metadata.yaml``. The folder opens in ``ros2
bag info`` / ``ros2 bag play`` on a ROS 2 Jazzy install and in ``rrps-replay``; each MCAP file
opens in Foxglove.
"""

from __future__ import annotations

import argparse
import sys
from typing import Sequence

__all__ = ['main', 'parser']


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='rrps-record',
        description='Record every rrps topic, /diagnostics, /tf and /tf_static to a rosbag2 bag folder '
                    '(metadata.yaml and MCAP files: CDR messages, ros2msg schemas, offered QoS), '
                    'with a flight recorder that writes the last seconds when a fault is reported.')
    p.add_argument('-o', '--output', default='rrps_recordings', help='folder of the bag folders')
    p.add_argument('--prefix', default='',
                   help='name of the bag folder in --output (default rrps_<date>_<time>; must not exist)')
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
    """The recorder_node parameters of the command-line options."""
    out = ['-r', f'__ns:={args.namespace}', '-p', f'output_dir:={args.output}',
           '-p', f'max_file_size_mb:={float(args.max_size)}',
           '-p', f'max_file_duration:={float(args.max_duration)}',
           '-p', f'compression:={args.compression}', '-p', f'buffer_seconds:={float(args.buffer)}',
           '-p', f'record:={"false" if args.flight_recorder_only else "true"}',
           '-p', f'flight_recorder:={"false" if args.no_flight_recorder else "true"}',
           '-p', f'robot:={args.robot}']
    if args.prefix:
        out += ['-p', f'prefix:={args.prefix}']
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
    from rrps_recording.nodes.recorder_node import RecorderNode
    from rrps_runtime.process import run_nodes
    run_nodes([RecorderNode], ['rrps-record', '--ros-args', *ros_arguments(args),
                               *argv[split + 1:]])
    return 0


if __name__ == '__main__':
    sys.exit(main())
