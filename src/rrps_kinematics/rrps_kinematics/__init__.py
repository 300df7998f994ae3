"""rrps_kinematics: kinematics and multibody core of RRPS parallel climbing robots.

Pure Python/NumPy (no ROS import outside ``rrps_kinematics.nodes``); robots come from
:mod:`rrps_description`. IK (eq. 1), FK and all assembly modes (§2.2), limits as signed margins,
and the multibody model (eqs. 2-12; imported on first use, it compiles with numba). Examples:
docs/usage.md, 'Python API'.
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
