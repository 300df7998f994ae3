#!/usr/bin/env python3
"""Benchmark of the plan's jerk limiting: the moving average of the TOPP-RA profile against Ruckig
tracking the same profile, on the same paths, in the same run.

    python benchmarks/jerk_limiting.py

For each shipped climber on its structure, the motions of one planned step are cut into their
pieces between corners (as ``rrps_climbing.timing`` times them); each piece's time-optimal
profile s(t) under the legs' speed and acceleration (TOPP-RA, the planner's
``rrps_description.motion_limits.stream_limits``) is made jerk-limited three ways:

* ``moving average``: what the planner does (``timing_profile.SmoothedLaw``: the profile averaged
  over the window the legs' jerk limit needs, slowed uniformly until every sample keeps every leg
  limit: ``timing._time_piece``);
* ``ruckig path``: Ruckig (``ruckig``, the pinned online trajectory generator) on the path
  parameter, tracking the profile's state (s, ṡ) every 2 ms within the profile's largest path
  speed and acceleration and the path jerk the legs allow where they move fastest (the planner's
  jerk bound of the window), then to the end at rest;
* ``ruckig legs``: Ruckig on the six leg lengths, tracking the profile's leg lengths and rates
  every 2 ms within the legs' speed, acceleration and jerk limits, then to the
  end lengths at rest (the pose by forward kinematics).

Figures, from samples every 2 ms: the largest distance of the pose from the planned path
(position, and the characteristic length times the rotation: the path the planner checked; on
the path parameter, how far it runs past either end of the path), the
largest ratio of a leg's speed, acceleration or jerk (finite differences) to its limit, and the
motion's duration against the moving average's. Targets (MET/MISSED): path deviation <= 0.1 mm
(the planner checks the path, not a neighbourhood), every leg limit kept (ratio <= 1.001), the
duration no longer than the moving average's + 2 %. The moving average is the planner's only if
Ruckig misses a target here: ``timing_profile`` names this benchmark.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import ruckig

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.path_curve import PathCurve, corner_pieces
from rrps_climbing.timing import SAMPLE_PERIOD, _time_piece, _topp
from rrps_climbing.timing_constraints import grid_limits
from rrps_climbing.timing_profile import TimingLaw
from rrps_description.geometry import load_robot
from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_description.structures import make_structure
from rrps_kinematics.forward import ForwardSolver

CASES = [('pole_climber', 'pole'), ('frame_climber', 'frame'), ('facade_climber', 'facade')]
H = SAMPLE_PERIOD
DEVIATION = 1e-4      # [m]
LIMIT_RATIO = 1.001
DURATION = 1.02


def leg_ratios(lengths: np.ndarray, legs: ActuatorLimits, valid=None) -> float:
    """The largest |speed|, |acceleration|, |jerk| of leg-length samples H apart over their limits
    (only differences of ``valid`` samples, when given)."""
    valid = np.ones(len(lengths), dtype=bool) if valid is None else valid
    worst = 0.0
    for k, limit in ((1, legs.speed), (2, legs.acceleration), (3, legs.jerk)):
        d = np.abs(np.diff(lengths, n=k, axis=0)).max(axis=1) / H ** k / limit
        ok = np.all([valid[i:len(valid) - k + i] for i in range(k + 1)], axis=0)
        worst = max(worst, float(d[ok].max()))
    return worst


def deviation(curve: PathCurve, positions, quaternions, c: float) -> float:
    """The largest distance [m] of poses from the path (nearest of 4000 path samples; the
    rotation's angle times the characteristic length ``c``)."""
    s = np.linspace(0.0, curve.length, 4001)
    p, q = curve.poses(s)
    worst = 0.0
    for pk, qk in zip(positions, quaternions):
        dot = np.clip(np.abs(q @ qk), 0.0, 1.0)
        d = np.sqrt(np.sum((p - pk) ** 2, axis=1) + (c * 2.0 * np.arccos(dot)) ** 2)
        worst = max(worst, float(d.min()))
    return worst


def track(n: int, reference, end, limits: tuple, steps: int) -> np.ndarray:
    """Ruckig (``n`` DOF) following ``reference(k)`` -> (p, v) at each of ``steps`` samples (each
    a target state, its speed within the limit, at zero acceleration: a target acceleration at
    the limits is one Ruckig cannot always stop from within them), then to ``end`` at rest; its
    positions every H."""
    otg, inp, out = ruckig.Ruckig(n, H), ruckig.InputParameter(n), ruckig.OutputParameter(n)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = ([float(x)] * n for x in limits)
    p0 = reference(0)[0]
    inp.current_position, inp.current_velocity, inp.current_acceleration = list(p0), [0.0] * n, [0.0] * n
    positions = [np.array(p0)]
    for k in range(1, steps + 10 ** 6):
        p, v = reference(k) if k <= steps else (end, np.zeros(n))
        v = np.clip(v, -limits[0], limits[0])
        inp.target_position, inp.target_velocity, inp.target_acceleration = list(p), list(v), [0.0] * n
        result = otg.update(inp, out)
        positions.append(np.array(out.new_position))
        out.pass_to_input(inp)
        if k > steps and result == ruckig.Result.Finished:
            break
    return np.array(positions)


def compare(geometry, curve: PathCurve) -> dict:
    legs = stream_limits(geometry.motion_limits.legs)
    c = geometry.characteristic_length
    law, _, _ = _time_piece(geometry, curve, legs, None, None, (1, 'move'))
    s_grid = np.linspace(0.0, curve.length, max(16, math.ceil(curve.length / 0.005)) + 1)
    profile = TimingLaw(s_grid, _topp(grid_limits(geometry, curve, s_grid, speed=legs.speed,
                                                  acceleration=legs.acceleration), curve.length, (1, 'move')))
    out = {}
    t = np.arange(math.ceil(law.duration / H) + 1) * H
    s = law.evaluate(t)[0]
    out['moving average'] = (0.0, leg_ratios(curve.leg_rates(geometry, s)[0], legs), law.duration)
    steps = math.ceil(profile.duration / H)
    _, ps, pv, pa = profile.evaluate(np.arange(steps + 1) * H)
    _, L1max, _ = curve.leg_rates(geometry, s_grid)
    path_jerk = legs.jerk / max(float(np.max(np.abs(L1max))), 1e-12)
    path = track(1, lambda k: ([ps[k]], [pv[k]]), [curve.length],
                 (max(pv.max(), 1e-9), max(np.abs(pa).max(), 1e-9), path_jerk), steps)[:, 0]
    # on the path while 0 <= s <= its length; beyond an end the pose leaves it (by that much of the
    # path metric) or, held at the end, stops dead: those samples are the deviation, not the limits
    inside = (path >= 0.0) & (path <= curve.length)
    beyond = max(0.0, -float(path.min()), float(path.max()) - curve.length)
    out['ruckig path'] = (beyond, leg_ratios(curve.leg_rates(geometry, path)[0], legs, inside), (len(path) - 1) * H)
    L, L1, L2 = curve.leg_rates(geometry, ps)
    Lv = L1 * pv[:, None]
    lengths = track(6, lambda k: (L[k], Lv[k]), L[-1], (legs.speed, legs.acceleration, legs.jerk), steps)
    fk = ForwardSolver(geometry)
    p, q = curve.poses(np.array([0.0]))
    poses = []
    for lk in lengths:
        r = fk(lk, p[0], q[0])
        p, q = np.array([r.position]), np.array([r.quaternion_xyzw])
        poses.append((r.position, r.quaternion_xyzw))
    dev = deviation(curve, [x for x, _ in poses], [y for _, y in poses], c)
    out['ruckig legs'] = (dev, leg_ratios(lengths, legs), (len(lengths) - 1) * H)
    return out


def main(argv=None) -> int:
    argparse.ArgumentParser(description=__doc__.split('\n')[0]).parse_args(argv)
    print('| robot / structure | method | pieces | path deviation (max) | leg limit ratio (max) | duration vs '
          'moving average | verdict |')
    print('|---|---|---|---|---|---|---|')
    missed_by_ruckig = set()
    for robot, structure in CASES:
        g = load_robot(robot)
        planner = GaitPlanner(g, make_structure(structure), loads=None)
        plan = planner.plan(planner.default_step, 1)
        rows: dict[str, list] = {}
        for ph in plan.phases:
            if ph.timing is None:
                continue
            for piece in corner_pieces(ph.path, g.characteristic_length):
                curve = PathCurve(ph.path[piece], ph.ring_angles[piece], characteristic_length=g.characteristic_length)
                if curve.length <= 0.0:
                    continue
                for method, figures in compare(g, curve).items():
                    rows.setdefault(method, []).append(figures)
        base = sum(d for _, _, d in rows['moving average'])
        for method, figures in rows.items():
            dev = max(f[0] for f in figures)
            ratio = max(f[1] for f in figures)
            duration = sum(f[2] for f in figures) / base
            verdicts = [dev <= DEVIATION, ratio <= LIMIT_RATIO, duration <= DURATION]
            met = all(verdicts)
            if method != 'moving average' and not met:
                missed_by_ruckig.add(method)
            words = ', '.join(f'{name} {"MET" if ok else "MISSED"}'
                              for name, ok in zip(('path', 'limits', 'duration'), verdicts))
            print(f'| {robot} / {structure} | {method} | {len(figures)} | {dev * 1e3:.3f} mm | {ratio:.3f} | '
                  f'{duration:.3f} | {words} |')
    print(f'\nRuckig misses a target ({", ".join(sorted(missed_by_ruckig)) or "none"}): '
          + ('the moving average stays' if len(missed_by_ruckig) == 2 else 'Ruckig would do'))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
