"""rrps_kinematics: kinematics and multibody core of RRPS parallel climbing robots.

Pure Python/NumPy (no ROS import outside ``rrps_kinematics.nodes``); robots come from
:mod:`rrps_description`. The public API::

    from rrps_description import load_robot
    from rrps_kinematics import inverse_kinematics, forward_kinematics
    geom = load_robot('pole_climber')                          # or a robot YAML path
    ik = inverse_kinematics(geom, position, quaternion_xyzw)   # single pose or (N,3), (N,4)
    fk = forward_kinematics(geom, lengths, seed_position, seed_quaternion_xyzw)
    solve = ForwardSolver(geom); fk = solve(lengths, fk.position, fk.quaternion_xyzw)  # a stream
    m = margins(geom, ik); m.ok, m.violations()                 # limits as signed margins
    ok, reason, m = check_pose(geom, position, quaternion_xyzw)
    modes = assembly_modes(geom, lengths)                        # every real FK solution
    model = MultibodyModel(geom)                                 # 13 bodies, 91 coordinates
    dk = model.direct_kinematics(lengths, model.coordinates_from_pose(position, quaternion_xyzw))

The multibody model is imported on first use (it compiles with numba).
"""

from rrps_kinematics.assembly import AssemblyModes, assembly_modes
from rrps_kinematics.forward import (
    ForwardKinematicsResult,
    ForwardSolver,
    compiled_backend_available,
    forward_kinematics,
)
from rrps_kinematics.inverse import InverseKinematicsResult, inverse_kinematics, leg_lengths
from rrps_kinematics.jacobian import inverse_jacobian, leg_forces, leg_rates, platform_wrench
from rrps_kinematics.limits import PAIRS, Margins, check_pose, margins

_LAZY = {'MultibodyModel': 'multibody', 'MultibodyDKResult': 'multibody'}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(f'.{_LAZY[name]}', __name__), name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


__all__ = [
    'AssemblyModes',
    'ForwardKinematicsResult',
    'ForwardSolver',
    'InverseKinematicsResult',
    'Margins',
    'MultibodyDKResult',
    'MultibodyModel',
    'PAIRS',
    'assembly_modes',
    'check_pose',
    'compiled_backend_available',
    'forward_kinematics',
    'inverse_jacobian',
    'inverse_kinematics',
    'leg_forces',
    'leg_lengths',
    'leg_rates',
    'margins',
    'platform_wrench',
]
