#!/usr/bin/env python3
"""Cost of one guarded teleop step with the load guards on (the default) against off, same run.

    python benchmarks/teleop_guards.py [--steps 1500] [--rounds 2]

:meth:`rrps_teleop.mapping.TeleopMapping.step` of the pole climber in Cartesian mode, driven at
200 Hz by a master on a scripted path, timed step by step (``time.perf_counter``); the runs are
interleaved round by round so that they share the machine's load. Scenarios:

* ``free``: ring_a upright, no payload, a Lissajous path: the loads stay far from their limits,
  the load guards evaluate one pose's statics per step;
* ``near holding``: ring_a on a wall, 120 kg on ring_b, the master going sideways towards the
  gripper's slipping and back (8 s period): in the band every step towards it is scaled (a second
  pose and its statics).

Each with the guards' and the statics' kernels compiled (numba) and interpreted (``RRPS_NUMBA=0``'s
path). Target (the budget of a guard on by default): a load-guarded compiled step's median within
0.25 ms, 5 % of the 5 ms period of a 200 Hz master: MET/MISSED (the p99 is printed; on a shared
machine it measures the other processes' preemptions more than the step).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.world import Support
from rrps_teleop.mapping import TeleopConfig, TeleopMapping
from rrps_teleop.master import scripted_pose

DT = 0.005
TARGET_P50 = 0.25e-3
WALL = Support.of('ring_a', [0.70710678, 0.0, 0.0, 0.70710678])


def scenario(name: str):
    """(slave geometry, support, master pose at time t)."""
    g = load_robot('pole_climber')
    q0 = np.array([0.0, 0.0, 0.0, 1.0])
    if name == 'free':
        return g, Support.of(), lambda t: scripted_pose('lissajous', t, np.zeros(3), q0, amplitude=0.004,
                                                        period=4.0, angular_amplitude=0.04)
    return (g.with_(payload=Payload(ring='ring_b', mass=120.0)), WALL,
            lambda t: (np.array([0.015 * (1.0 - np.cos(2.0 * np.pi * t / 8.0)), 0.0, 0.0]), q0))


def run(name: str, backend: str, guards: bool, steps: int) -> tuple[np.ndarray, set]:
    g, support, master = scenario(name)
    mapping = TeleopMapping(g, TeleopConfig(load_guards=guards, max_linear_speed=0.05), backend=backend,
                            support=support)
    mapping.on_slave_pose(g.home_position, g.home_quaternion_xyzw)
    times = np.empty(steps)
    codes = set()
    for k in range(steps):
        t = k * DT
        mapping.on_enable(t, True)
        mapping.on_master_pose(t, *master(t))
        t0 = time.perf_counter()
        out = mapping.step(t)
        times[k] = time.perf_counter() - t0
        codes.add(out.code.name)
        if out.has_command:
            mapping.on_slave_pose(out.position, out.quaternion_xyzw, t)
    return times[10:], codes


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--steps', type=int, default=1500)
    parser.add_argument('--rounds', type=int, default=2)
    args = parser.parse_args(argv)
    runs = [(s, b, guards) for s in ('free', 'near holding') for b in ('numba', 'numpy') for guards in (False, True)]
    samples = {r: [] for r in runs}
    codes = {r: set() for r in runs}
    for r in runs:
        run(*r, steps=50)                                   # warm-up: numba loads or compiles
    for _ in range(args.rounds):
        for r in runs:
            times, seen = run(*r, steps=args.steps)
            samples[r].append(times)
            codes[r] |= seen
    print(f'rrps teleop guard cost: Python {platform.python_version()}, {os.cpu_count()} CPUs, load average '
          f'{os.getloadavg()[0]:.1f}, {args.rounds} x {args.steps} steps of 5 ms each')
    header = (f'{"scenario":13s} {"backend":8s} {"load guards":12s} {"p50 [us]":>9s} {"p99 [us]":>9s} '
              f'{"x off":>6s}  codes')
    print(header)
    print('-' * (len(header) + 40))
    verdict = True
    for r in runs:
        t = np.concatenate(samples[r])
        off = np.median(np.concatenate(samples[(r[0], r[1], False)]))
        p50, p99 = np.median(t), np.percentile(t, 99)
        if r[1] == 'numba' and r[2]:
            verdict &= p50 <= TARGET_P50
        print(f'{r[0]:13s} {r[1]:8s} {"on" if r[2] else "off":12s} {p50 * 1e6:9.1f} {p99 * 1e6:9.1f} '
              f'{p50 / off:6.2f}  {", ".join(sorted(codes[r]))}')
    print('-' * (len(header) + 40))
    print(f'target: compiled load-guarded step p50 <= {TARGET_P50 * 1e3:g} ms: {"MET" if verdict else "MISSED"}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
