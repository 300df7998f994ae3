"""``rrps-climb``: plan an inchworm climb and write it as CSV (no ROS needed).

Options, CSV columns and the load check: docs/usage.md ('Command-line tools'); the frame node and
routes: docs/frame_node.md. Each motion is timed by :mod:`rrps_climbing.timing`, its loads
checked by :mod:`rrps_climbing.load_check`. Exit status: 0 planned, 1 refused (the message names
the limit, the legs or ring, the step and phase), 2 bad arguments (one line on stderr), 3 a bug.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import traceback
from typing import Sequence

from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.gait import GaitPlanner
from rrps_climbing.load_check import LoadCheck
from rrps_climbing.plan import CSV_COLUMNS, PlanError
from rrps_climbing.route import ROUTES, plan_route
from rrps_description.structures import STRUCTURES, make_structure
from rrps_description.world import IDENTITY_QUATERNION, STANDARD_GRAVITY
from rrps_kinematics.cli_support import (
    EXIT_BUG,
    EXIT_FAILED,
    EXIT_USAGE,
    OneLineParser,
    UsageError,
    count,
    join_negative_vectors,
    load_robot_or_usage_error,
    vector,
)
from rrps_sim.cli_world import LOAD_VECTOR_OPTIONS, add_load_options, with_loads

PROG = 'rrps-climb'
_VECTOR_OPTIONS = ('--structure-quaternion', '--gravity') + LOAD_VECTOR_OPTIONS


def _distance(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a number, got {text!r}')
    if not math.isfinite(value) or value == 0.0:
        raise argparse.ArgumentTypeError(f'must be a finite non-zero number, got {text!r}')
    return value


def build_parser() -> OneLineParser:
    p = OneLineParser(prog=PROG, description='Plan an inchworm climb of an RRPS robot along a '
                      'structure, checking every limit along every motion and the gripper '
                      'interlock; write one CSV row per phase.')
    p.add_argument('--robot', default='pole_climber', help='shipped robot name or YAML path')
    p.add_argument('--structure', required=True, choices=sorted(STRUCTURES) + sorted(ROUTES))
    p.add_argument('--distance', type=_distance,
                   help='route distance to climb [m] (negative: down); required without --junction-deg')
    p.add_argument('--steps', type=count, help='number of steps (default: as few as the reach allows)')
    p.add_argument('--start', type=float, help='route position of ring_a at the start [m]')
    p.add_argument('--no-extra-dof', action='store_true',
                   help='do not use the extra ring DOF (frame climber)')
    p.add_argument('--junction-deg', type=_junction,
                   help='frame only: plan the crossing of a node bent by this angle [deg] (1 .. 90)')
    p.add_argument('--out-of-plane', action='store_true',
                   help="with --junction-deg: the member bends normal to the column's web plane")
    p.add_argument('--bends', type=_bends, metavar='DEG,DEG',
                   help='frame_route: the bend of each node [deg] (default 30,30)')
    p.add_argument('--corner-deg', type=float, default=20.0,
                   help='facade_corner: the corner [deg], positive outside (default 20)')
    p.add_argument('--csv', help='write the plan to this CSV file')
    p.add_argument('--speed', type=float, metavar='M/S',
                   help="cap on the moving ring's path speed [m/s] (default: none, the legs' limits alone)")
    p.add_argument('--structure-quaternion', type=vector(4), metavar='QX,QY,QZ,QW',
                   help="the structure's attitude in the world (default identity: as built)")
    p.add_argument('--gravity', type=vector(3), metavar='GX,GY,GZ',
                   help="the world's gravity [m/s^2] (default 0,0,-9.81)")
    add_load_options(p)
    return p


def _bends(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(','))
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected comma-separated angles [deg], got {text!r}')
    if not all(math.isfinite(v) and 1.0 <= v <= 90.0 for v in values):
        raise argparse.ArgumentTypeError(f'each bend must be in 1 .. 90 deg, got {text!r}')
    return values


def _junction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a number, got {text!r}')
    if not (math.isfinite(value) and 1.0 <= value <= 90.0):
        raise argparse.ArgumentTypeError(f'must be in 1 .. 90 deg, got {text!r}')
    return value


def _plan(args, geometry, loads: LoadCheck):
    """(planner, plan, structure) for the parsed arguments."""
    if args.junction_deg is not None:
        if args.structure != 'frame':
            raise UsageError('--junction-deg needs --structure frame')
        if args.distance is not None or args.steps is not None or args.start is not None:
            raise UsageError('--junction-deg plans the crossing from its searched stance: '
                             'leave out --distance, --steps and --start')
        planner = FrameNodePlanner(geometry, args.junction_deg, args.out_of_plane,
                                   use_extra_dof=not args.no_extra_dof)
        return planner, planner.plan_crossing(), planner.structure
    if args.out_of_plane:
        raise UsageError('--out-of-plane needs --junction-deg')
    if args.distance is None:
        raise UsageError('--distance is required (or --junction-deg with --structure frame)')
    if args.structure in ROUTES:
        if args.steps is not None:
            raise UsageError(f'--steps does not apply to the {args.structure} (its steps follow the route)')
        return plan_route(geometry, args.structure, args.distance, start=args.start, corner_deg=args.corner_deg,
                          bends_deg=(30.0, 30.0) if args.bends is None else args.bends,
                          use_extra_dof=not args.no_extra_dof, loads=loads,
                          gravity=None if args.gravity is None else tuple(args.gravity))
    needed = abs(args.distance) + (args.start or 0.0) + 1.5 * geometry.max_length + 0.3
    structure = make_structure(args.structure, needed)
    planner = GaitPlanner(geometry, structure, use_extra_dof=not args.no_extra_dof, loads=loads)
    return planner, planner.plan(args.distance, args.steps, start=args.start), structure


def _print_crossing(planner: FrameNodePlanner, plan) -> None:
    """The crossing's phases and margins, the searched loads of its motions."""
    c = planner.crossing
    print(f'{plan.robot}: {planner.title}: face {"+" if c.candidate.side > 0 else "-"}n, '
          f'{c.evaluated} candidates searched, smallest scaled margin {c.score:.3f}')
    print('  step phase       s_a [m] s_b [m] theta_a/b [deg] stroke  cones  interf. clear.  cond.  '
          'peak force [N] holding')
    for ph in plan.phases:
        m = ph.min_margins
        loads = ''
        if ph.phase in c.margins:
            force, leg = c.peak_force[ph.phase]
            loads = f' {force:8.1f} leg_{leg} {c.margins[ph.phase]["holding"]:7.3f}'
        print(f'  {ph.step:4d} {ph.phase:10s} {ph.s_a:7.3f} {ph.s_b:7.3f} {math.degrees(ph.theta_a):6.1f}/'
              f'{math.degrees(ph.theta_b):6.1f}  {m["stroke"]:6.3f} {min(m["universal"], m["spherical"]):6.3f} '
              f'{m["interference"]:7.3f} {m["clearance"]:6.3f} {m["conditioning"]:6.3f}{loads}')


def _load_check(args) -> LoadCheck:
    try:
        return LoadCheck(speed=args.speed,
                         world_q_structure=tuple(IDENTITY_QUATERNION if args.structure_quaternion is None
                                                 else args.structure_quaternion),
                         gravity=tuple(STANDARD_GRAVITY if args.gravity is None else args.gravity))
    except ValueError as exc:
        raise UsageError(str(exc).replace('world_q_support', '--structure-quaternion', 1)) from None


def _load_line(plan, geometry) -> str:
    peak = plan.peak_load
    if peak is None:
        return '  loads: no phase with one gripper holding'
    payload = geometry.payload
    carried = f'payload {payload.mass:.1f} kg on {payload.ring}' if payload is not None else 'no payload'
    holding = ('no holding capacity rated' if math.isnan(peak.holding_margin)
               else f'smallest holding margin {peak.holding_margin:.3f} ({peak.holding_ring})')
    return (f'  loads ({carried}): peak actuator force {peak.peak_force:.1f} N ({peak.peak_leg}; limit '
            f'{geometry.max_force:.0f} N), {holding}')


def _timing_line(plan, speed) -> str:
    """Each step's duration and the climbing speed; where a requested speed was capped."""
    steps = plan.step_durations()
    per_step = ', '.join(f'{k}: {d:.1f} s' for k, d in steps.items())
    text = (f'  timing: {plan.duration:.1f} s in all, per step {per_step}; climbing speed '
            f'{plan.climbing_speed:.2f} m/min')
    capped = LoadCheck.capped(plan.phases)
    if capped:
        fastest = max(ph.timing.peak_speed for ph in capped)
        text += (f'\n  speed: {speed:g} m/s requested, capped to what the legs allow ({fastest:.3f} m/s at most, '
                 f'step {capped[0].step} {capped[0].phase} and {len(capped) - 1} more motions)')
    return text


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = build_parser().parse_args(join_negative_vectors(argv, _VECTOR_OPTIONS))
        geometry = with_loads(load_robot_or_usage_error(args.robot), args)
        loads = _load_check(args)
        try:
            planner, plan, structure = _plan(args, geometry, loads)
        except PlanError:
            raise
        except ValueError as exc:  # input the planner cannot use (off the structure, ...)
            raise UsageError(str(exc)) from None
    except UsageError as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return EXIT_USAGE
    except PlanError as exc:
        at = ', '.join(f'{k} {v:.4f}' for k, v in exc.margins.items() if not math.isnan(v))
        print(f'{PROG}: refused: {exc}' + (f' [margins there: {at}]' if at else ''), file=sys.stderr)
        return EXIT_FAILED
    except Exception:  # a bug: its traceback, never a usage error
        traceback.print_exc()
        print(f'{PROG}: internal error (a bug; the traceback above says where)', file=sys.stderr)
        return EXIT_BUG
    if args.csv:
        try:
            with open(args.csv, 'w', newline='') as f:
                writer = csv.DictWriter(f, fieldnames=CSV_COLUMNS)
                writer.writeheader()
                for row in plan.rows():
                    writer.writerow({k: (f'{v:.6f}' if isinstance(v, float) else v) for k, v in row.items()})
        except OSError as exc:
            print(f'{PROG}: error: cannot write {args.csv}: {exc.strerror}', file=sys.stderr)
            return EXIT_USAGE
    if args.junction_deg is not None:
        _print_crossing(planner, plan)
        if args.csv:
            print(f'  wrote {len(plan.phases)} rows to {args.csv}')
        return 0
    last = plan.phases[-1]
    m = plan.min_margins
    print(f'{plan.robot} on {plan.structure} ({structure.length:.2f} m route): {plan.steps} steps of '
          f'{plan.step_length * 1000:.1f} mm, {len(plan.phases)} phases, ring_a climbed '
          f'{plan.climbed:.3f} m (reach {planner.reach[0]:.3f} .. {planner.reach[1]:.3f} m)')
    print(f'  ring_a ends at world ({", ".join(f"{v:.3f}" for v in last.world_T_a.position)}), '
          f'ring_b at ({", ".join(f"{v:.3f}" for v in last.world_T_b.position)}) m'
          + (f'; extra DOF {math.degrees(last.theta_a):.0f} / {math.degrees(last.theta_b):.0f} deg'
             if planner.dof else ''))
    print('  smallest margins: ' + ', '.join(
        f'{k} {v:.4f}' for k, v in m.items() if not math.isnan(v))
        + '  (m; joint angles rad; conditioning dimensionless)')
    print(_load_line(plan, geometry))
    print(_timing_line(plan, args.speed))
    if args.csv:
        print(f'  wrote {len(plan.phases)} rows to {args.csv}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
