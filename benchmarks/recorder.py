"""Recorder cost: the demo's robot stack at 500 Hz with teleop motion, recorder off vs on.

Starts the demo's processes with the demo's priorities (the driver at 500 Hz and the robot's
IK, FK and climbing real-time, the operator station's master and teleop real-time behind them,
the master running its circle trajectory while this script holds the deadman, so IK streams
commands and the driver moves; the recorder, like the demo's observers, at nice +5), then
measures phases of ``--seconds`` each in the same run, with a "recorder off" phase between any
two others:

* a bare raw listener of the same topics (``_raw_listener.py``: receipt only, what a separate
  Python subscriber pays before it writes a byte);
* the recorder subscribing to every topic (``use_taps:=false``: how it worked before the
  recording taps);
* ``--cycles`` times, the recorder as shipped (``rrps-record``: every topic at full rate to a
  zstd MCAP file, the high-rate ones from the nodes' recording taps, the 60 s flight-recorder
  ring and /tf at 10 Hz), each followed by a control: ``_cpu_load.py``, a process that only
  burns as much CPU as the recorder did (what any process of that CPU costs the stack here).

``--climb`` starts a climb step at the start of every phase as well (up, down, ...).

* CPU: user + system time of every process of the stack (and the recorder's), from
  /proc/<pid>/stat, over the phase, in % of one core, in all and per process. The stack's own CPU drifts by a few % of
  a core between phases on a shared machine, so each phase is compared with the mean of the
  "off" phases on either side of it; the recorder's cost is the mean over its cycles, with its
  standard error.
* The driver's period: differences of the ``actuators/state`` header stamps (its timer),
  received by this separate process; p50, p99, max.

Targets: the recorder adds < 10 % to the stack's CPU; the driver's period p99 does
not change (within the spread of the recorder-off phases, at least 0.25 ms). The recording of
the first "recorder on" phase is read back with the mcap reader: channels, counts, size.

    python benchmarks/recorder.py [--seconds 12] [--cycles 6] [--climb]
    python benchmarks/recorder.py --session 60     # one recorded session: teleop, then a climb

``--session S`` records one session instead: teleop motion for the first third, then the
deadman is released and a climb step up runs, S seconds in all; it prints the file's channels,
message counts and size (no off/on comparison).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 80))

from rrps_testing.processes import cpu_seconds, stop_processes, wait_until  # noqa: E402


def _report_files(files) -> None:
    from mcap.reader import make_reader
    total = sum(f.stat().st_size for f in files)
    for f in files:
        with open(f, 'rb') as stream:
            summary = make_reader(stream).get_summary()
        st = summary.statistics
        seconds = (st.message_end_time - st.message_start_time) * 1e-9
        print(f'{f.name}: {f.stat().st_size / 1e6:.2f} MB, {seconds:.1f} s, {st.message_count} '
              f'messages, {st.chunk_count} zstd chunks')
        print(f'{"channel":<32}{"schema":<40}{"messages":>10}{"rate [Hz]":>11}')
        for cid, channel in sorted(summary.channels.items(), key=lambda c: c[1].topic):
            n = st.channel_message_counts.get(cid, 0)
            print(f'{channel.topic:<32}{summary.schemas[channel.schema_id].name:<40}{n:>10d}'
                  f'{n / max(seconds, 1e-9):>11.1f}')
    print(f'total {total / 1e6:.2f} MB')


def _session(seconds: float, out_dir: Path, deadman, climb, Trigger) -> int:
    """Record ``seconds`` of teleop motion, then a climb step; print the recording."""
    from rrps_runtime.supervision import stop_child
    recorder = subprocess.Popen(
        [sys.executable, '-m', 'rrps_recording.record_cli', '-o', str(out_dir / 'session'),
         '--namespace', '/rrps'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        time.sleep(3.0)  # discovery
        t0 = time.monotonic()
        time.sleep(seconds / 3.0)
        deadman.clear()
        time.sleep(0.5)
        future = climb['up'].call_async(Trigger.Request())
        wait_until(future.done, 10.0)
        response = future.result()
        print(f'climb step up: {response.message if response else "no answer"}')
        time.sleep(max(0.0, seconds - (time.monotonic() - t0)))
    finally:
        stop_child(recorder, timeout=30.0)
    print(f'\nA {seconds:g} s session (teleop motion, then a climb step), recorded by rrps-record:')
    _report_files(sorted((out_dir / 'session').glob('session_*.mcap')))
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=12.0, help='length of each phase [s]')
    parser.add_argument('--cycles', type=int, default=6, help='recorder off/on cycles')
    parser.add_argument('--climb', action='store_true', help='a climb step in every phase')
    parser.add_argument('--session', type=float, default=0.0,
                        help='record one teleop + climb session of this many seconds instead')
    args = parser.parse_args()

    import rclpy
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool
    from std_srvs.srv import Trigger

    from rrps_bringup.demo_processes import start_driver, start_robot_nodes
    from rrps_bringup.params import params_file_arguments
    from rrps_runtime.messages import stamp_to_seconds
    from rrps_runtime.process import make_executor, spin_until_shutdown
    from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
    from rrps_runtime.supervision import OBSERVER_NICE, OPERATOR_NICE, OPERATOR_RT_PRIORITY, start_child, stop_child

    stack = [start_driver(robot='pole_climber', activate=True), start_robot_nodes(robot='pole_climber'),
             start_child([sys.executable, '-m', 'rrps_bringup.compose', 'master_node',
                          'teleop_node', '--ros-args',
                          *params_file_arguments('master_node', 'teleop_node'),
                          '-r', '__ns:=/rrps'], nice=OPERATOR_NICE, realtime=OPERATOR_RT_PRIORITY)]
    context = rclpy.Context()
    rclpy.init(context=context)
    stop = threading.Event()
    node = Node('recorder_benchmark', context=context, namespace='/rrps')
    stamps: list[tuple[float, float]] = []
    lock = threading.Lock()

    def on_state(msg) -> None:
        with lock:
            stamps.append((time.monotonic(), stamp_to_seconds(msg.header.stamp)))

    node.create_subscription(JointState, 'actuators/state', on_state, STATE_QOS)
    enable = node.create_publisher(Bool, 'teleop/enable', COMMAND_QOS)
    deadman = threading.Event()
    deadman.set()
    node.create_timer(0.05, lambda: deadman.is_set() and enable.publish(Bool(data=True)))
    climb = {'up': node.create_client(Trigger, 'climb/step_up'),
             'down': node.create_client(Trigger, 'climb/step_down')}
    executor = make_executor(context, 'events')
    executor.add_node(node)
    spinner = threading.Thread(target=spin_until_shutdown, args=(executor, context, stop),
                               daemon=True)
    spinner.start()
    out_dir = Path(tempfile.mkdtemp(prefix='rrps-recorder-bench-'))
    recorder = None
    phases = []
    try:
        client = node.create_client(SetParameters, 'master_node/set_parameters')
        if not (client.wait_for_service(timeout_sec=60.0)
                and climb['up'].wait_for_service(timeout_sec=60.0)
                and wait_until(lambda: len(stamps) > 100, 60.0)):
            print('error: the stack did not come up', file=sys.stderr)
            return 1
        future = client.call_async(SetParameters.Request(parameters=[Parameter(
            name='trajectory', value=ParameterValue(type=ParameterType.PARAMETER_STRING,
                                                    string_value='circle'))]))
        wait_until(future.done, 10.0)
        time.sleep(3.0)
        if args.session > 0.0:
            return _session(args.session, out_dir, deadman, climb, Trigger)
        pids = [p.pid for p in stack]
        record = [sys.executable, '-m', 'rrps_recording.record_cli', '--namespace', '/rrps']
        listener = [sys.executable, str(Path(__file__).resolve().parent / '_raw_listener.py'),
                    '--namespace', '/rrps']
        # The stack's own CPU drifts by several % of a core from one phase to the next on a
        # shared machine, so "off" phases alternate with the others and each is compared with
        # the mean of the "off" phases on either side of it; the recorder runs --cycles times,
        # each followed by the control: a bare CPU load of the recorder's own CPU so far.
        plan = [('recorder off', None), ('bare raw listener', 'listener'),
                ('recorder off', None), ('recorder, no taps', 'recorder_dds')]
        for _ in range(args.cycles):
            plan += [('recorder off', None), ('recorder on', 'recorder'),
                     ('recorder off', None), ('same CPU, no ROS', 'load')]
        plan.append(('recorder off', None))
        for i, (name, kind) in enumerate(plan):
            if kind is not None:
                duty = np.mean([p[2] for p in phases if p[0] == 'recorder on'] or [5.0]) / 100
                command = {'listener': listener,
                           'load': [sys.executable, str(Path(__file__).resolve().parent
                                                        / '_cpu_load.py'), f'{duty:.4f}'],
                           'recorder': record + ['-o', str(out_dir / f'phase{i}')],
                           'recorder_dds': record + ['-o', str(out_dir / f'phase{i}'), '--ros-args',
                                                     '-p', 'use_taps:=false']}[kind]
                recorder = start_child(command, nice=OBSERVER_NICE, stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL)
                time.sleep(4.0)  # start-up and discovery are not part of the phase
            if args.climb:
                climb['up' if i % 2 == 0 else 'down'].call_async(Trigger.Request())
            measured = pids + ([recorder.pid] if kind else [])
            c0, t0 = [cpu_seconds([pid]) for pid in measured], time.monotonic()
            time.sleep(args.seconds)
            c1, t1 = [cpu_seconds([pid]) for pid in measured], time.monotonic()
            each = [100.0 * (b - a) / (t1 - t0) for a, b in zip(c0, c1)]
            with lock:
                s = np.array([stamp for recv, stamp in stamps if t0 <= recv < t1])
            phases.append((name, sum(each), each[len(pids)] if kind else 0.0, np.diff(s), each[:len(pids)]))
            if kind:
                stop_child(recorder, timeout=30.0)
    finally:
        stop.set()
        spinner.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        if recorder is not None and recorder.poll() is None:
            recorder.kill()
        stop_processes(stack, timeout=10.0)

    print(f'\nRecorder cost: demo robot stack (driver 500 Hz, IK, FK, climb, master, teleop) '
          f'with teleop motion{" and climbing" if args.climb else ""}, {args.seconds:g} s per '
          f'phase, {os.cpu_count()} CPUs (shared)')
    print(f'{"phase":<20}{"stack CPU [% core]":>20}{"of it rec./lis.":>16}'
          f'{"period p50 [ms]":>17}{"p99 [ms]":>10}{"max [ms]":>10}{"states":>8}')
    for name, cpu, rec_cpu, p, _ in phases:
        print(f'{name:<20}{cpu:>20.1f}{rec_cpu:>16.1f}{1e3 * np.median(p):>17.3f}'
              f'{1e3 * np.percentile(p, 99):>10.3f}{1e3 * np.max(p):>10.3f}{len(p) + 1:>8d}')
    def added_by(index, cpu=lambda phase: phase[1]):
        """A phase's stack CPU (or ``cpu`` of it) minus that of the "off" phases on either side."""
        around = [cpu(phases[j]) for j in (index - 1, index + 1)
                  if 0 <= j < len(phases) and phases[j][0] == 'recorder off']
        return cpu(phases[index]) - float(np.mean(around))

    def of(name):
        return [i for i, phase in enumerate(phases) if phase[0] == name]

    base_cpu = float(np.mean([phases[i][1] for i in of('recorder off')]))
    on = np.array([added_by(i) for i in of('recorder on')])
    added = float(on.mean())
    error = float(on.std(ddof=1) / np.sqrt(len(on))) if len(on) > 1 else float('nan')
    subscribed = added_by(of('recorder, no taps')[0])
    bare = added_by(of('bare raw listener')[0])
    recorder_itself = float(np.mean([phases[i][2] for i in of('recorder on')]))
    control = np.array([added_by(i) for i in of('same CPU, no ROS')])
    p99_off = [1e3 * np.percentile(phases[i][3], 99) for i in of('recorder off')]
    p99_on = float(np.mean([1e3 * np.percentile(phases[i][3], 99) for i in of('recorder on')]))
    noise = max(0.25, max(p99_off) - min(p99_off))
    cpu_ok = added < 0.10 * base_cpu
    p99_ok = abs(p99_on - float(np.mean(p99_off))) <= noise
    print(f'\nCPU added by the recorder ({len(on)} phases, each against the "off" phases around '
          f'it): {added:+.1f} +/- {error:.1f} % of a core (per phase: '
          f'{", ".join(f"{x:+.1f}" for x in on)}) = {100 * added / base_cpu:+.1f} % of the '
          f'stack\'s {base_cpu:.1f} % (target < 10 %): {"MET" if cpu_ok else "MISSED"}; the '
          f'recorder process itself {recorder_itself:.1f} %, the rest is the stack\'s taps')
    processes = ('driver', 'IK, FK, climb', 'master, teleop')
    print('of which each process of the stack, recorder on / the control [% of a core]: ' + ', '.join(
        f'{who} {np.mean([added_by(i, lambda ph: ph[4][k]) for i in of("recorder on")]):+.1f} / '
        f'{np.mean([added_by(i, lambda ph: ph[4][k]) for i in of("same CPU, no ROS")]):+.1f}'
        for k, who in enumerate(processes)))
    print(f'CPU added by a process that only burns the recorder\'s CPU (the control, same run): '
          f'{control.mean():+.1f} +/- '
          f'{control.std(ddof=1) / np.sqrt(len(control)) if len(control) > 1 else float("nan"):.1f}'
          f' % of a core (per phase: {", ".join(f"{x:+.1f}" for x in control)}): what any '
          f'process of that CPU costs the stack on this machine')
    print(f'CPU added by a bare raw listener of the same topics (what a separate subscriber pays '
          f'to receive every message, same run): {bare:+.1f} % of a core = '
          f'{100 * bare / base_cpu:+.1f} % of the stack')
    print(f'CPU added by the recorder subscribing to every topic (use_taps:=false, same run): '
          f'{subscribed:+.1f} % of a core = {100 * subscribed / base_cpu:+.1f} % of the stack')
    print(f'driver period p99: {p99_on:.3f} ms on vs {" / ".join(f"{p:.3f}" for p in p99_off)} ms off '
          f'(noise {noise:.3f} ms): {"MET" if p99_ok else "MISSED"}')

    first_on = next(i for i, (_, kind) in enumerate(plan) if kind == 'recorder')
    print(f'\nrecording of the first "recorder on" phase ({out_dir}):')
    _report_files(sorted((out_dir / f'phase{first_on}').glob('*.mcap')))
    return 0 if cpu_ok and p99_ok else 1


if __name__ == '__main__':
    sys.exit(main())
