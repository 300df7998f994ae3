#!/usr/bin/env python3
"""Benchmark of ``rrps-dynamics simulate --csv`` against the library call it wraps.

    python benchmarks/simulate_cli.py [--robot pole_climber] [--duration 0.5] [--dt 0.001] [--repeats 5]

The paper's run (constant actuator forces from rest, hybrid RK4) through
``rrps_sim.dynamics.simulate`` and through the command line in this process (``run([...])``:
parsing, the robot's YAML, the run, the CSV to a temporary file), every step written and every
10th (``--output-every 10``), and, as the same-run baseline, the command line writing its CSV as
it did before (a ``csv.writer`` row of ``repr(float(x))`` per step). Runs alternate, best of
``--repeats`` each, timed in CPU time of this process (single-threaded; the 2 cores are shared).
Target: the command line within 10 % of the library call per step.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rrps_description.geometry import load_robot
from rrps_sim import cli
from rrps_sim.dynamics import MultibodyDynamics, simulate
from rrps_sim.figures import REPORT_EXTRA_FORCES
from rrps_sim.float_text import csv_rows

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
    parser.add_argument('--dt', type=float, default=0.001)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args(argv)
    g = load_robot(args.robot)
    position, quat = g.home_position, g.home_quaternion_xyzw
    quat = quat / np.linalg.norm(quat)
    forces = MultibodyDynamics(g).holding_forces(position, quat) + REPORT_EXTRA_FORCES
    steps = int(round(args.duration / args.dt))
    out = Path(tempfile.mkdtemp(prefix='rrps-simulate-cli-')) / 'run.csv'
    command = ['simulate', '--robot', args.robot, '--forces', ','.join(map(repr, forces.tolist())),
               '--duration', repr(args.duration), '--dt', repr(args.dt), '--csv', str(out)]

    def library(every):
        return lambda: simulate(g, position, quat, forces, duration=args.duration, dt=args.dt,
                                output_every=every)

    def command_line(every, writer=None):
        def go():
            quiet = io.StringIO()
            with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
                if writer is None:
                    status = cli.run(command + ['--output-every', str(every)])
                else:
                    kept, cli._write_csv = cli._write_csv, writer
                    try:
                        status = cli.run(command + ['--output-every', str(every)])
                    finally:
                        cli._write_csv = kept
            if status != 0:
                raise RuntimeError(f'rrps-dynamics simulate failed: {quiet.getvalue()}')
        return go

    runs = {'library, every step': library(1),
            'command line, every step': command_line(1),
            'command line, every step, per-row csv.writer (before)': command_line(1, per_row_writer),
            'library, output_every=10': library(10),
            'command line, --output-every 10': command_line(10)}
    for fn in runs.values():           # warm-up: numba compiles or loads its cache here
        fn()
    cpu = dict.fromkeys(runs, np.inf)
    wall = dict.fromkeys(runs, np.inf)
    for _ in range(args.repeats):
        for name, fn in runs.items():
            c, w = timed(fn)
            cpu[name], wall[name] = min(cpu[name], c), min(wall[name], w)
    us = {name: 1e6 * sec / steps for name, sec in cpu.items()}
    us_wall = {name: 1e6 * sec / steps for name, sec in wall.items()}

    rows = cli.simulation_rows(simulate(g, position, quat, forces, duration=args.duration,
                                        dt=args.dt))
    reprs = tuple(rows.ravel().tolist())
    line = ','.join(['%r'] * rows.shape[1]) + '\r\n'
    text = {'compiled (float_text.csv_rows)': lambda: csv_rows(rows),
            "bulk '%r' formatting (the RRPS_NUMBA=0 path)": lambda: (line * len(rows)) % reprs}
    text_us = {name: 1e6 * min(timed(fn)[0] for _ in range(args.repeats)) / len(rows)
               for name, fn in text.items()}
    same = csv_rows(rows).decode() == (line * len(rows)) % reprs

    print(f'# rrps-dynamics simulate --csv vs simulate(): {g.name}, {args.duration} s at '
          f'{1e3 * args.dt:g} ms (hybrid), {steps} steps, {rows.shape[1]} columns; '
          f'{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python '
          f'{sys.version.split()[0]}')
    width = max(len(name) for name in list(runs) + list(text))
    base = {1: us['library, every step'], 10: us['library, output_every=10']}
    for name in runs:
        every = 10 if '10' in name else 1
        print(f'{name:{width}s}  {us[name]:8.2f} us/step  {us[name] / base[every]:5.2f}x library'
              f'  (wall {us_wall[name]:.2f} us/step)')
    for name, value in text_us.items():
        print(f'{name:{width}s}  {value:8.2f} us/row   the CSV text of one step')
    print(f'compiled text equals repr of every value: {same}')
    print()
    verdicts = {f'every {every}': us[name] / base[every]
                for every, name in ((1, 'command line, every step'),
                                    (10, 'command line, --output-every 10'))}
    for name, ratio in verdicts.items():
        print(f'command line / library, {name}: {ratio:.3f} (target <= {TARGET:.2f}): '
              f'{"MET" if ratio <= TARGET else "MISSED"}')
    return 0 if same and all(r <= TARGET for r in verdicts.values()) else 1


if __name__ == '__main__':
    sys.exit(main())
