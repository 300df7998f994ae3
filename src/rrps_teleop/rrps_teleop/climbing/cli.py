"""``rrps-climb``: plan an inchworm climb and write it as CSV (no ROS needed).

    rrps-climb --robot pole_climber --structure {pole,palm_trunk,frame,facade} --distance 3.0
               [--steps N] [--start S] [--no-extra-dof] [--csv plan.csv]
               [--speed M/S] [--structure-quaternion QX,QY,QZ,QW] [--gravity GX,GY,GZ]
               [--payload-mass KG [--payload-com X,Y,Z] [--payload-ring ring_a|ring_b]]
               [--tool-force FX,FY,FZ] [--tool-torque TX,TY,TZ] [--tool-frame tool|world]

One CSV row per phase: ``step, phase, gripper_a, gripper_b`` (1 closed, 0 open), the route
positions ``s_a, s_b``, the world poses of both rings (``a_x..a_qw``, ``b_x..b_qw``, from the
odometry chain), the kinematic pose a_T_b (``px..qw``), the extra-DOF angles, the leg lengths
``L1..L6`` [m], the smallest margin of each kind over the phase, and for a phase during which
one gripper holds its peak actuator force [N] and smallest holding margin
(:mod:`rrps_teleop.climbing.load_check`: the motions streamed at ``--speed``, the structure
turned by ``--structure-quaternion`` in a world of ``--gravity``, the payload and tool wrench of
the robot or of the command line). A negative distance climbs down. Exit status: 0 planned,
1 refused (a limit would break: the message says which, on which legs or ring, at which step
and phase), 2 bad arguments (one line on stderr), 3 a bug (its traceback).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import traceback
from typing import Sequence

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
    positive,
    vector,
)
from rrps_sim.cli_world import LOAD_VECTOR_OPTIONS, add_load_options, with_loads
from rrps_teleop.climbing.gait import GaitPlanner
from rrps_teleop.climbing.load_check import DEFAULT_SPEED, LoadCheck
from rrps_teleop.climbing.plan import CSV_COLUMNS, PlanError

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
    p.add_argument('--structure', required=True, choices=sorted(STRUCTURES))
    p.add_argument('--distance', required=True, type=_distance,
                   help='route distance to climb [m] (negative: down)')
    p.add_argument('--steps', type=count, help='number of steps (default: as few as the reach allows)')
    p.add_argument('--start', type=float, help='route position of ring_a at the start [m]')
    p.add_argument('--no-extra-dof', action='store_true',
                   help='do not use the extra ring DOF (frame climber)')
    p.add_argument('--csv', help='write the plan to this CSV file')
    p.add_argument('--speed', type=positive, default=DEFAULT_SPEED,
                   help=f'speed the motions are streamed at, for their loads [m/s] (default {DEFAULT_SPEED})')
    p.add_argument('--structure-quaternion', type=vector(4), metavar='QX,QY,QZ,QW',
                   help="the structure's attitude in the world (default identity: as built)")
    p.add_argument('--gravity', type=vector(3), metavar='GX,GY,GZ',
                   help="the world's gravity [m/s^2] (default 0,0,-9.81)")
    add_load_options(p)
    return p


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


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = build_parser().parse_args(join_negative_vectors(argv, _VECTOR_OPTIONS))
        geometry = with_loads(load_robot_or_usage_error(args.robot), args)
        loads = _load_check(args)
        needed = abs(args.distance) + (args.start or 0.0) + 1.5 * geometry.max_length + 0.3
        structure = make_structure(args.structure, needed)
        try:
            planner = GaitPlanner(geometry, structure, use_extra_dof=not args.no_extra_dof, loads=loads)
            plan = planner.plan(args.distance, args.steps, start=args.start)
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
    if args.csv:
        print(f'  wrote {len(plan.phases)} rows to {args.csv}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
