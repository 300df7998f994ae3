#!/usr/bin/env python3
"""Benchmark of the climbing timing: climbing speed at the legs' limits, loads of the timed motion,
planning time and the jerk of the streamed setpoints, each against a same-run baseline.

    python benchmarks/climb_timing.py [--repeat 3]

For each shipped climber on its structure (the master robot climbs nothing), without payload and
with the demo scenarios' payloads (15 kg on the facade climber's ring_b on its wall, 40 kg on
the pole climber's ring_b on a pole leaning 30 deg), a 1 m climb is planned (``GaitPlanner``:
TOPP-RA timing, loads checked) and compared with:

* ``today``: the same path streamed at the former constant 0.02 m/s (arc length plus the
  characteristic length times the angle), with the same gripper times;
* ``bound``: the fastest the legs' speed and acceleration (their full limits) allow along the
  same paths, computed here independently by the classic phase-plane integration (forward pass
  at the largest path acceleration, backward pass at the largest deceleration, the leg rates
  L'(s), L''(s) by finite differences of the IK lengths): a lower bound of any motion's
  duration. Climbing speed = the route distance of steps 1.. over their duration (step 0, the
  first contraction, left out), gripper open/close times included in all three.

Targets (MET/MISSED): the planned climbing speed >= 90 % of the bound without payload; the
payload plans timed within every limit (peak force <= max_force, holding margin >= 0, checked on
the plan's loads); the planned peak force of step 1's motions within 5 % of the DAE preview of
the same timed step (``run_preview``); planning the 1 m climb with timing <= 1 s (best CPU time
of ``--repeat``, beside the geometric planning of the former release: the timing's share); the
streamed jerk (the climb node's 50 Hz stream through the driver's 500 Hz setpoints, finite
differences) within the legs' limit at every sample; those setpoints at most 0.1 mm of leg length
past a motion's last command once its stream ends (the end-of-motion overshoot).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rrps_climbing import load_check
from rrps_climbing.gait import GaitPlanner
from rrps_climbing.path_curve import PathCurve, path_metric
from rrps_climbing.step_preview import run_preview
from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.structures import make_structure
from rrps_hardware.setpoints import DRIVER_PERIOD, stream_setpoints
from rrps_interfaces.climb import PhaseAction
from rrps_kinematics import inverse_kinematics

CASES = [  # (robot, structure, lean [deg], payload [kg] on ring_b)
    ('pole_climber', 'pole', 0.0, 0.0), ('frame_climber', 'frame', 0.0, 0.0),
    ('facade_climber', 'facade', 0.0, 0.0), ('facade_climber', 'facade', 0.0, 15.0),
    ('pole_climber', 'pole', 30.0, 40.0)]
DISTANCE = 1.0
TODAY = 0.02          # the former constant path speed [m/s]
STREAM = 0.02         # the climb node's period [s]


def bound_time(geometry, phase) -> float:
    """The fastest rest-to-rest time along a motion's path under the legs' full speed and
    acceleration limits: forward and backward integration in the phase plane (x = ṡ²)."""
    legs = geometry.motion_limits.legs
    curve = PathCurve(phase.path, phase.ring_angles, characteristic_length=geometry.characteristic_length)
    s = np.linspace(0.0, curve.length, 4001)
    h = 1e-5 * curve.length
    lengths = [inverse_kinematics(geometry, *curve.poses(np.clip(s + d, 0.0, curve.length))).lengths
               for d in (-h, 0.0, h)]
    L1 = (lengths[2] - lengths[0]) / (2 * h)
    L2 = (lengths[2] - 2 * lengths[1] + lengths[0]) / h ** 2
    L1[0], L1[-1], L2[0], L2[-1] = L1[1], L1[-2], L2[1], L2[-2]      # one-sided at the ends
    x_max = np.min((legs.speed / np.maximum(np.abs(L1), 1e-12)) ** 2, axis=1)

    def u_range(k, x):
        lo, hi = -np.inf, np.inf
        for a, b in zip(L1[k], L2[k]):
            if abs(a) < 1e-12:
                continue
            ends = sorted(((-legs.acceleration - b * x) / a, (legs.acceleration - b * x) / a))
            lo, hi = max(lo, ends[0]), min(hi, ends[1])
        return lo, hi

    ds = np.diff(s)
    x = np.zeros(len(s))
    for k in range(len(s) - 1):                       # forward: accelerate as hard as allowed
        x[k + 1] = min(x_max[k + 1], max(x[k] + 2 * ds[k] * u_range(k, x[k])[1], 0.0))
    x[-1] = 0.0
    for k in range(len(s) - 2, -1, -1):               # backward: brake as hard as allowed
        x[k] = min(x[k], max(x[k + 1] - 2 * ds[k] * u_range(k + 1, x[k + 1])[0], 0.0))
    v = np.sqrt(x)
    return float(np.sum(2 * ds / np.maximum(v[:-1] + v[1:], 1e-12)))


def climbing_speed(plan, motion_time) -> float:
    """Route distance of steps 1.. per minute, the motions taking ``motion_time(phase)``."""
    total = sum(motion_time(ph) if ph.timing is not None else ph.duration for ph in plan.phases if ph.step >= 1)
    return 60.0 * abs(plan.climbed) / total


def streamed(geometry, plan) -> tuple[float, float, float]:
    """Step 1's motions streamed to the driver: the largest |jerk| of the plan's samples and of the
    driver's setpoints, and the farthest [m] a leg's setpoints go past its last command after the
    stream ends (in the direction the leg was moving)."""
    worst_plan = worst_driver = overshoot = 0.0
    for ph in plan.phases:
        if ph.step != 1 or ph.timing is None:
            continue
        fine = ph.timing.phase_path(DRIVER_PERIOD)
        L = inverse_kinematics(geometry, fine.positions, fine.quaternions_xyzw).lengths
        worst_plan = max(worst_plan, np.abs(np.diff(L, 3, axis=0)).max() / DRIVER_PERIOD ** 3)
        stream = ph.timing.phase_path(STREAM)
        commands = inverse_kinematics(geometry, stream.positions, stream.quaternions_xyzw).lengths
        setpoints = stream_setpoints(commands, STREAM, geometry.motion_limits.legs, settle=0.5)
        worst_driver = max(worst_driver, np.abs(np.diff(setpoints, 3, axis=0)).max() / DRIVER_PERIOD ** 3)
        last = int(round(STREAM * (len(commands) - 1) / DRIVER_PERIOD))
        heading = np.sign(commands[-1] - commands[-6])
        overshoot = max(overshoot, float(((setpoints[last:] - commands[-1]) * heading).max()))
    return worst_plan, worst_driver, overshoot


def best(fn, repeat):
    out, times = None, []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return out, min(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--repeat', type=int, default=3)
    args = parser.parse_args(argv)
    print(f'{"robot":15s} {"structure":14s} {"load":>5s} {"today":>6s} {"planned":>8s} {"bound":>6s} {"ratio":>6s} '
          f'{"s/step":>7s} {"peak F":>7s} {"preview":>8s} {"dF":>6s} {"plan 1 m":>9s} {"timing":>7s} '
          f'{"jerk plan/driver/limit":>24s} {"past":>9s}  verdicts')
    verdicts = []
    for robot, name, lean, payload in CASES:
        g = load_robot(robot)
        if payload:
            g = g.with_(payload=Payload(ring='ring_b', mass=payload))
        structure = make_structure(name, DISTANCE + 1.5 * g.max_length + 0.3, lean_deg=lean)
        planner = GaitPlanner(g, structure)
        plan, t_plan = best(lambda: planner.plan(DISTANCE), args.repeat)
        _, t_timing = best(lambda: load_check.time_phases(g, plan.phases, planner.loads), args.repeat)
        c = g.characteristic_length
        today = climbing_speed(plan, lambda ph: path_metric(ph.path, c)[-1] / TODAY)
        bound = climbing_speed(plan, lambda ph: bound_time(g, ph))
        planned = plan.climbing_speed
        step1 = [ph for ph in plan.phases if ph.step == 1]
        moves = [ph for ph in step1 if ph.action is PhaseAction.MOVE and ph.loads is not None]
        peak = max(ph.loads.peak_force for ph in moves)
        preview = run_preview(g, step1, period=STREAM)
        deviation = abs(preview.peak_force - peak) / preview.peak_force
        within = all(ph.loads.peak_force <= g.max_force and not ph.loads.holding_margin < 0.0
                     for ph in plan.phases if ph.loads is not None)
        jerk_plan, jerk_driver, overshoot = streamed(g, plan)
        limit = g.motion_limits.legs.jerk
        row = {
            'speed >= 90 % of bound': (planned >= 0.9 * bound) if not payload else None,
            'within every limit': within,
            'peak force within 5 % of preview': deviation <= 0.05,
            'plan 1 m <= 1 s': t_plan <= 1.0,
            'streamed jerk within limit': max(jerk_plan, jerk_driver) <= limit * (1 + 1e-6),
            'setpoints past the last command <= 0.1 mm': overshoot <= 1e-4,
        }
        marks = ', '.join(f'{k}: {"MET" if v else "MISSED"}' for k, v in row.items() if v is not None)
        verdicts += [v for v in row.values() if v is not None]
        steps = [d for k, d in plan.step_durations().items() if k >= 1]
        print(f'{robot:15s} {name + (f" {lean:.0f} deg" if lean else ""):14s} {payload:4.0f}k {today:6.2f} '
              f'{planned:8.2f} {bound:6.2f} {planned / bound:6.1%} {max(steps):7.2f} {peak:7.1f} '
              f'{preview.peak_force:8.1f} {deviation:6.1%} {t_plan:8.3f}s {t_timing:6.3f}s '
              f'{jerk_plan:7.2f}/{jerk_driver:5.2f}/{limit:5.2f} m/s3 {overshoot * 1e3:6.3f} mm  {marks}')
    print('climbing speeds in m/min; today: the same path at 0.02 m/s; bound: the legs\' full speed and '
          'acceleration, phase-plane integration written here')
    print(f'targets: {"all MET" if all(verdicts) else "some MISSED"}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
