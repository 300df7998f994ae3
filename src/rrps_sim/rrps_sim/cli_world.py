"""The world and load options of ``rrps-dynamics`` statics, simulate and inverse (support, gravity,
payload, tool wrench; see ``--help`` and docs/usage.md), and the statics' report (text or JSON).
"""

from __future__ import annotations

import json

import numpy as np

from rrps_description.geometry import RobotDescriptionError, RobotGeometry
from rrps_description.loads import WRENCH_FRAMES, Payload, ToolWrench
from rrps_description.names import LEG_NAMES, RINGS
from rrps_kinematics.cli_support import UsageError, vector
from rrps_loads.loads import StaticSolution
from rrps_loads.support import Support, support_of

__all__ = ['WORLD_VECTOR_OPTIONS', 'LOAD_VECTOR_OPTIONS', 'REACTION_COLUMNS', 'add_world_options',
           'add_load_options', 'world_of', 'with_loads',
           'statics_lines', 'statics_json', 'reaction_rows']

LOAD_VECTOR_OPTIONS = ('--payload-com', '--tool-force', '--tool-torque')
WORLD_VECTOR_OPTIONS = ('--support-quaternion', '--gravity') + LOAD_VECTOR_OPTIONS
#: The simulate CSV's columns with --reactions: each leg's universal- and spherical-joint
#: reaction [N] and the support's force [N] and moment [N m], in the supporting ring's frame.
REACTION_COLUMNS = ([f'U{i}{a}' for i in range(1, 7) for a in 'xyz']
                    + [f'S{i}{a}' for i in range(1, 7) for a in 'xyz']
                    + ['support_fx', 'support_fy', 'support_fz', 'support_mx', 'support_my', 'support_mz'])


def add_world_options(p) -> None:
    """The world and load options (module docstring) on a subcommand's parser."""
    p.add_argument('--support', choices=RINGS, default='ring_a',
                   help='the gripping ring, grounded (default ring_a)')
    p.add_argument('--support-quaternion', type=vector(4), metavar='QX,QY,QZ,QW',
                   help="the supporting ring's attitude in the world (default identity)")
    p.add_argument('--gravity', type=vector(3), metavar='GX,GY,GZ',
                   help="the world's gravity [m/s^2] (default 0,0,-9.81)")
    add_load_options(p)


def add_load_options(p) -> None:
    """The payload and tool-wrench options (module docstring), read by :func:`with_loads`."""
    p.add_argument('--payload-mass', type=float, metavar='KG', help='a point-mass payload [kg]')
    p.add_argument('--payload-com', type=vector(3), metavar='X,Y,Z',
                   help="the payload's com in its ring's frame [m] (default 0,0,0)")
    p.add_argument('--payload-ring', choices=RINGS, help='the ring carrying it (default ring_b)')
    p.add_argument('--tool-force', type=vector(3), metavar='FX,FY,FZ',
                   help='force on the tool-centre point [N]')
    p.add_argument('--tool-torque', type=vector(3), metavar='TX,TY,TZ',
                   help='torque on the tool [N m]')
    p.add_argument('--tool-frame', choices=WRENCH_FRAMES, default='tool',
                   help='frame of --tool-force and --tool-torque (default tool)')


def world_of(args) -> Support:
    """The supporting ring, its attitude and the world's gravity of the command line."""
    try:
        return support_of(args.support, args.support_quaternion, args.gravity)
    except ValueError as exc:
        raise UsageError(str(exc).replace('world_q_support', '--support-quaternion', 1)) from None


def with_loads(g: RobotGeometry, args) -> RobotGeometry:
    """The robot with the payload and tool wrench of the command line (if given)."""
    changes = {}
    if args.payload_mass is not None:
        changes['payload'] = Payload(ring=args.payload_ring or 'ring_b', mass=args.payload_mass,
                                     com=np.zeros(3) if args.payload_com is None else args.payload_com)
    elif args.payload_com is not None or args.payload_ring is not None:
        raise UsageError('--payload-com and --payload-ring need --payload-mass')
    if args.tool_force is not None or args.tool_torque is not None:
        changes['tool_wrench'] = ToolWrench(
            force=np.zeros(3) if args.tool_force is None else args.tool_force,
            torque=np.zeros(3) if args.tool_torque is None else args.tool_torque,
            frame=args.tool_frame)
    if not changes:
        return g
    try:
        return g.with_(**changes)
    except RobotDescriptionError as exc:
        raise UsageError(str(exc)) from None


def _numbers(values, digits: int = 6) -> str:
    return ', '.join(f'{float(v):.{digits}f}' for v in values)


def statics_lines(sol: StaticSolution) -> list[str]:
    """The statics report: ``leg_i: F N`` (+ pushes the rings apart), then the joint reactions,
    the support's wrench and the holding margin, in the supporting ring's frame."""
    ring = sol.support.ring
    lines = [f'{name}: {f:.6f} N' for name, f in zip(LEG_NAMES, sol.actuator_forces)]
    lines.append(f"support: {ring}; vectors in {ring}'s frame, where gravity is "
                 f'{_numbers(sol.support.gravity_in_support)} m/s^2')
    lines += [f'universal_{k + 1}: {_numbers(r)} N' for k, r in enumerate(sol.universal_reactions)]
    lines += [f'spherical_{k + 1}: {_numbers(r)} N' for k, r in enumerate(sol.spherical_reactions)]
    lines.append(f'support_force: {_numbers(sol.support_wrench[:3])} N')
    lines.append(f'support_moment: {_numbers(sol.support_wrench[3:])} N m')
    margin = float(sol.holding_margin)
    lines.append('holding_margin: ' + ('none rated' if np.isnan(margin) else f'{margin:.6f}'))
    return lines


def statics_json(g: RobotGeometry, position, quaternion, sol: StaticSolution) -> str:
    """Everything of :func:`statics_lines`, and the pose and the world, as one JSON object."""
    margin = float(sol.holding_margin)
    return json.dumps({
        'robot': g.name,
        'pose': {'position': list(map(float, position)), 'quaternion_xyzw': list(map(float, quaternion))},
        'support': sol.support.ring,
        'world_q_support': sol.support.world_q_support.tolist(),
        'gravity_world': sol.support.gravity.tolist(),
        'frame': sol.support.ring,
        'gravity_in_support': sol.support.gravity_in_support.tolist(),
        'actuator_forces': dict(zip(LEG_NAMES, sol.actuator_forces.tolist())),
        'universal_reactions': dict(zip(LEG_NAMES, sol.universal_reactions.tolist())),
        'spherical_reactions': dict(zip(LEG_NAMES, sol.spherical_reactions.tolist())),
        'support_wrench': {'force': sol.support_wrench[:3].tolist(), 'moment': sol.support_wrench[3:].tolist()},
        'holding_margin': None if np.isnan(margin) else margin,
    }, indent=2)


def reaction_rows(res) -> np.ndarray:
    """The REACTION_COLUMNS of a simulation run with reactions (K rows)."""
    k = len(res.t)
    return np.column_stack([res.universal_reactions.reshape(k, 18), res.spherical_reactions.reshape(k, 18),
                            res.support_wrench])
