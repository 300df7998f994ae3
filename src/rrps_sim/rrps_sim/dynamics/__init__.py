"""Forward dynamics of the 13-body RRPS model: the DAE of eqs. 19-20 (paper section 2.3), with
either ring gripping.

Positions are the 91 coordinates of :mod:`rrps_kinematics.multibody` (com and Euler parameters
of the free ring and the 12 leg links, in the supporting ring's frame); velocities are
v = [ṙ_b, ω'_b] per body (78,), ω' in the body frame. With actuator *forces* applied (not
lengths), the 72 joint constraints Φ^K leave 6 DOF.

The supporting ring is the ground and the free ring body 0, the hub. The constraints keep the
joints where they are (:mod:`.constraints`): with ring_b gripping, the universal joints ride on
the moving ring_a (eqs. 4-5 gain its coordinates) and the spherical joints sit at fixed points
of ring_b (eq. 3 loses them). The model stays 13 bodies and 91 coordinates, each leg still
couples to the hub through one joint's rows (3 or 4), so the structured solve of eq. 19, the
three integrators and the partitioning carry over exactly. Flipping the robot instead (ring_b
as the base of the ring_a-grounded model) would swap the joint types: the legs' spin about their
axes would follow the ground rather than ring_a. For axisymmetric links the spin enters only
through their axial inertia (I_axial σ̇ = the axial torque), so the flip is exact only for
massless spin; ``tests/unit/sim/test_world_dynamics.py`` shows the error it makes otherwise. A
14-body model with the support as constraints would lose the hub structure of the solve.

* :mod:`.bundles`: the typed bundles the kernels take (robot, workspace, observations).
* :mod:`.constraints`: a leg's rows of Φ_x and γ (eqs. 3-10).
* :mod:`.kernels`: eq. 19 at one state, solved by the robot's structure, its multipliers as
  joint reactions (compiled).
* :mod:`.observation`: what is observed of a state: lengths, drift, energies (compiled).
* :mod:`.integrators`: RK4 with Baumgarte stabilisation, coordinate partitioning or the hybrid
  of both, a whole step and a whole run compiled.
* :mod:`.frames`: the coordinates in the supporting ring's frame, the pose a_T_b back.
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
