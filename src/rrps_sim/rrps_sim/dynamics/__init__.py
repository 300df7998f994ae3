"""Forward dynamics of the 13-body RRPS model: the DAE of eqs. 19-20 (§2.3), with either ring gripping.

Positions are the 91 coordinates of :mod:`rrps_kinematics.multibody` in the supporting ring's
frame, velocities v = [ṙ_b, ω'_b] per body (78,), ω' in the body frame; with actuator forces
applied, the 72 joint constraints leave 6 DOF. The supporting ring is the ground, the free ring
body 0, the hub (:mod:`.constraints`; why not a flipped robot: docs/architecture.md, 'rrps_sim').
The submodules are listed in docs/architecture.md.
"""

from rrps_sim.dynamics.bundles import DynamicsParameters, Observation, Observations
from rrps_sim.dynamics.flops import EVALUATION_FLOPS, NEWTON_LEG_FLOPS, VELOCITY_LEG_FLOPS, step_flops
from rrps_sim.dynamics.integrators import METHODS
from rrps_sim.dynamics.model import MultibodyDynamics, RunRecord
from rrps_sim.dynamics.simulation import SimulationResult, simulate

__all__ = [
    'EVALUATION_FLOPS',
    'METHODS',
    'NEWTON_LEG_FLOPS',
    'VELOCITY_LEG_FLOPS',
    'DynamicsParameters',
    'MultibodyDynamics',
    'Observation',
    'Observations',
    'RunRecord',
    'SimulationResult',
    'simulate',
    'step_flops',
]
