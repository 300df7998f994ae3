"""Forward dynamics of the 13-body RRPS model: the DAE of eqs. 19-20 (paper section 2.3).

Positions are the 91 coordinates of :mod:`rrps_kinematics.multibody` (com and Euler parameters
of ring_b and the 12 leg links); velocities are v = [ṙ_b, ω'_b] per body (78,), ω' in the body
frame. With actuator *forces* applied (not lengths), the 72 joint constraints Φ^K leave 6 DOF.

* :mod:`.bundles`: the typed bundles the kernels take (robot, workspace, observations).
* :mod:`.constraints`: a leg's rows of Φ_x and γ (eqs. 3-10).
* :mod:`.kernels`: eq. 19 at one state, solved by the robot's structure, and what is observed
  of a state (compiled).
* :mod:`.integrators`: RK4 with Baumgarte stabilisation, coordinate partitioning or the hybrid
  of both, a whole step and a whole run compiled.
* :mod:`.model`: :class:`MultibodyDynamics`, one robot's state stepped by the caller.
* :mod:`.simulation`: :func:`simulate`, a batch run from rest, recorded step by step.
* :mod:`.flops`: the flop model of a step (the paper's Figure 7).
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
