#!/usr/bin/env python3
"""Benchmark of ``rrps-dynamics simulate --npz`` (and ``--csv``) against the library call it wraps.

    python benchmarks/simulate_cli.py [--robot pole_climber] [--duration 0.5] [--long 10]
                                      [--dt 0.001] [--repeats 9]

The paper's run (constant actuator forces from rest, hybrid RK4) through
``rrps_sim.dynamics.simulate`` and through the command line in this process (``run([...])``:
parsing, the robot's YAML, the run, the output to a temporary file): the bulk output
(``--npz``, NumPy's archive) every step and every 10th (``--output-every 10``), every step with
the joint reactions (``--reactions``, 76 columns; not a target), the CSV (``--csv``, written by
``numpy.savetxt``; not a target) and, as the same-run baseline, the command line writing its CSV
as it did first (a ``csv.writer`` row of ``repr(float(x))`` per step). Runs alternate, best of
``--repeats`` each, timed in CPU time of this process (single-threaded; the 2 cores are shared),
for a ``--duration`` s run and one ``--long`` times longer. Target: the command line's bulk
output within 10 % of the library call per step, i.e. the slope of the CPU time over the run's
steps between the two runs; the whole runs' ratios and what the command line costs once per
invocation whatever the run's length (its "own cost") are printed beside it.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import csv
import io
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rrps_description.geometry import load_robot
from rrps_sim import cli
from rrps_sim.dynamics import MultibodyDynamics, simulate
from rrps_sim.figures import REPORT_EXTRA_FORCES

TARGET = 1.10            # command line / library, per step


def per_row_writer(path: Path, header, rows: np.ndarray) -> None:
    """The baseline: the command line's CSV writer before (one csv.writer row per step)."""
    with open(path, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for row in rows:
            w.writerow([repr(float(x)) for x in row])


def timed(fn) -> tuple[float, float]:
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robot', default='pole_climber')
    parser.add_argument('--duration', type=float, default=0.5)
    parser.add_argument('--long', type=float, default=10.0,
                        help='the longer run: this many times --duration (default 10)')
    parser.add_argument('--dt', type=float, default=0.001)
    parser.add_argument('--repeats', type=int, default=9)
    args = parser.parse_args(argv)
    g = load_robot(args.robot)
    position, quat = g.home_position, g.home_quaternion_xyzw
    quat = quat / np.linalg.norm(quat)
    forces = MultibodyDynamics(g).holding_forces(position, quat) + REPORT_EXTRA_FORCES
    folder = Path(tempfile.mkdtemp(prefix='rrps-simulate-cli-'))
    atexit.register(shutil.rmtree, folder, True)  # the runs' CSV and NPZ files go with the process
    out, npz = folder / 'run.csv', folder / 'run.npz'

    def library(duration, every, reactions=False):
        return lambda: simulate(g, position, quat, forces, duration=duration, dt=args.dt,
                                output_every=every, reactions=reactions)

    def command_line(duration, every, writer=None, reactions=False, csv_file=False):
        command = ['simulate', '--robot', args.robot, '--forces',
                   ','.join(map(repr, forces.tolist())), '--duration', repr(duration),
                   '--dt', repr(args.dt), '--output-every', str(every)]
        command += ['--csv', str(out)] if csv_file or writer else ['--npz', str(npz)]
        command += ['--reactions'] if reactions else []

        def go():
            quiet = io.StringIO()
            kept = cli._write_csv
            cli._write_csv = writer or kept
            try:
                with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
                    status = cli.run(command)
            finally:
                cli._write_csv = kept
            if status != 0:
                raise RuntimeError(f'rrps-dynamics simulate failed: {quiet.getvalue()}')
        return go

    durations = (args.duration, args.long * args.duration)
    runs = {}
    modes = ('every 1', 'every 10', 'every 1, reactions')
    for duration in durations:
        runs[duration, modes[0], 'library'] = library(duration, 1)
        runs[duration, modes[0], 'command line'] = command_line(duration, 1)
        runs[duration, modes[0], 'command line --csv (numpy.savetxt)'] = command_line(duration, 1, csv_file=True)
        runs[duration, modes[0], 'command line --csv first (per-row csv.writer)'] = \
            command_line(duration, 1, per_row_writer)
        runs[duration, modes[1], 'library'] = library(duration, 10)
        runs[duration, modes[1], 'command line'] = command_line(duration, 10)
        runs[duration, modes[2], 'library'] = library(duration, 1, reactions=True)
        runs[duration, modes[2], 'command line'] = command_line(duration, 1, reactions=True)
    library(0.01, 1)()                 # warm-up: numba compiles or loads its cache here
    command_line(0.01, 1)()
    cpu = dict.fromkeys(runs, np.inf)
    wall = dict.fromkeys(runs, np.inf)
    for _ in range(args.repeats):
        for key, fn in runs.items():
            c, w = timed(fn)
            cpu[key], wall[key] = min(cpu[key], c), min(wall[key], w)

    rows = cli.simulation_rows(simulate(g, position, quat, forces, duration=args.duration,
                                        dt=args.dt))
    text = {'NumPy archive (--npz)': lambda: cli._write_npz(npz, cli.SIMULATION_COLUMNS, rows),
            'numpy.savetxt (--csv)': lambda: cli._write_csv(out, cli.SIMULATION_COLUMNS, rows),
            'per-row csv.writer of repr (first)': lambda: per_row_writer(out, [], rows)}
    text_us = {name: 1e6 * min(timed(fn)[0] for _ in range(args.repeats)) / len(rows)
               for name, fn in text.items()}
    cli._write_csv(out, cli.SIMULATION_COLUMNS, rows)
    with open(out, newline='') as fh:
        lines = list(csv.reader(fh))[1:]
    archive = np.load(npz)
    same = (all(cell == repr(v) for line, row in zip(lines, rows.tolist()) for cell, v in zip(line, row))
            and all(np.array_equal(archive[name], rows[:, k], equal_nan=True)
                    for k, name in enumerate(cli.SIMULATION_COLUMNS)))

    print(f'# rrps-dynamics simulate --csv vs simulate(): {g.name}, hybrid RK4 at '
          f'{1e3 * args.dt:g} ms, {rows.shape[1]} columns; CPU time, best of {args.repeats}; '
          f'{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python '
          f'{sys.version.split()[0]}')
    print(f'{"run":6s} {"output":19s} {"what":46s} {"us/step":>8s} {"x library":>9s} '
          f'{"own cost":>9s}  wall us/step')
    ratios = {}
    for (duration, mode, what), sec in cpu.items():
        steps = int(round(duration / args.dt))
        base = cpu[duration, mode, 'library']
        ratios[duration, mode, what] = sec / base
        print(f'{f"{duration:g} s":6s} {mode:19s} {what:46s} {1e6 * sec / steps:8.2f} '
              f'{sec / base:9.3f} {f"{1e3 * (sec - base):.2f} ms":>9s}  '
              f'{1e6 * wall[duration, mode, what] / steps:.2f}')
    print()
    for name, value in text_us.items():
        print(f'output of one step, {name}: {value:.2f} us')
    print(f'the CSV holds repr of every value and the archive every value to the bit: {same}')
    print()
    short, long = durations
    steps = int(round(long / args.dt)) - int(round(short / args.dt))
    met = []
    for mode in modes:
        slope = {what: (cpu[long, mode, what] - cpu[short, mode, what]) / steps
                 for what in ('library', 'command line')}
        ratio = slope['command line'] / slope['library']
        verdict = 'MET' if ratio <= TARGET else 'MISSED'
        if mode in modes[:2]:
            met.append(ratio <= TARGET)
        else:
            verdict += ' (not a target: 76 columns)'
        print(f'per step (the slope from the {short:g} s to the {long:g} s run), output {mode}: '
              f'command line {1e6 * slope["command line"]:.2f} us, library '
              f'{1e6 * slope["library"]:.2f} us, ratio {ratio:.3f} (target <= {TARGET:.2f}): '
              f'{verdict}')
    for duration in durations:
        for mode in modes[:2]:
            ratio = ratios[duration, mode, 'command line']
            own = cpu[duration, mode, 'command line'] - cpu[duration, mode, 'library']
            print(f'whole {duration:g} s run, output {mode}: command line / library '
                  f'{ratio:.3f} (within 10 %: {"MET" if ratio <= TARGET else "MISSED"}; the '
                  f'command line\'s own cost {1e3 * own:.1f} ms)')
    print('(own cost: what the command line adds to the library call: once per invocation the '
          'arguments, the robot YAML, the progress batches, the CSV file and the summary; per '
          'written row its CSV text)')
    return 0 if same and all(met) else 1


if __name__ == '__main__':
    sys.exit(main())
