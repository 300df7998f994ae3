"""Flop model of the dynamics (paper Figure 7's cost per step): multiply, add, divide and square
root count one each.

The counts follow the loops of the kernels, by formula: one evaluation of eq. 19
(:func:`rrps_sim.dynamics.kernels.accelerations`) and of the state derivative, the RK4 updates,
the hybrid's drift check, one Newton iteration of a leg's dependent coordinates and one leg's
velocity solve (:func:`rrps_sim.dynamics.integrators.solve_dependent`).
"""

from __future__ import annotations

import numpy as np

from rrps_kinematics.multibody import FLOPS_LEG_JACOBIAN, FLOPS_LEG_RESIDUAL, FLOPS_ROTATION

__all__ = ['EVALUATION_FLOPS', 'NEWTON_LEG_FLOPS', 'VELOCITY_LEG_FLOPS', 'step_flops']

# One leg of an evaluation of eq. 19:
_LEG_BLOCKS = 13 * 3 * 3 * 5 + 700        # [Φ_r Φ_π'] and γ: Φ_π' = Φ_π A, vectors, crosses
_LEG_SOLVE = (2 * 3 * 12 + 2 * 9          # K: rows 9-10 with the translations eliminated, γ'
              + sum(1 + (5 - j) * (1 + 2 * (9 - j)) for j in range(6))   # 6 x 10 elimination
              + 4 * 36 + 4 * 36)          # back substitution and translations, 4 right-hand sides
_LEG_COUPLING = (4 * 36                   # M_l [H | c]
                 + 12 * 19                # Λ = H^T M_l H, w = H^T (F_l - M_l c)
                 + 9 * 5 + 3 * 34         # Λ Y; S += P^T Λ P, t -= P^T w
                 + 18 + 12 * 6)           # P a_b, a_l = c - H P a_b
_LEG = _LEG_BLOCKS + 12 + _LEG_SOLVE + _LEG_COUPLING   # 12: the actuator force on both links
#: Per leg and evaluation with Baumgarte terms: Φ (rotations given), Φ̇ = Φ_x v, γ update.
_BAUMGARTE_LEG = FLOPS_LEG_RESIDUAL - 2 * FLOPS_ROTATION + 12 * 18 * 2 + 12 * 6
#: One evaluation of eq. 19: 13 rotations, F^A and gyroscopic terms, six legs, ring_b's 6 x 6
#: Cholesky factorisation (91) and solve (72).
EVALUATION_FLOPS = 13 * FLOPS_ROTATION + 13 * 27 + 6 * _LEG + 91 + 72
#: The rest of a state derivative: ṗ = ½ G^T ω' of 13 bodies, Σ f_k L̇_k from ring_b's state.
_DERIVATIVE = 13 * 24 + 15 + 6 * 50
#: RK4's stage states (3 x 2 flops) and final update (7 flops) of 91 + 78 states, and the work.
_RK4_UPDATE = 13 * (91 + 78) + 7
#: The hybrid's check: 13 rotations, ‖Φ^K‖ (rotations given), the 13 Euler-parameter norms.
_DRIFT_CHECK = 13 * FLOPS_ROTATION + 6 * (FLOPS_LEG_RESIDUAL - 2 * FLOPS_ROTATION + 24) + 1 + 13 * 8
#: Partitioning's independent states: ring_b's ṗ and Σ f L̇ per stage, RK4 on 12 states.
_PARTITIONED_STATES = 4 * (18 + 15 + 6 * 50) + 13 * 12 + 7
#: One Newton iteration on a leg's 14 dependent coordinates: residual, Jacobian, 14 x 14 LU.
NEWTON_LEG_FLOPS = FLOPS_LEG_RESIDUAL + FLOPS_LEG_JACOBIAN + (2 * 14**3) // 3 + 2 * 14**2
#: One leg's dependent velocities from Φ_q v = 0 (eq. 20): blocks and a 12 x 12 LU.
VELOCITY_LEG_FLOPS = _LEG_BLOCKS + (2 * 12**3) // 3 + 2 * 12**2 + 12 * 6 * 2


def step_flops(method: str, baumgarte: bool, newton_iterations, corrected):
    """Flops of RK4 steps of ``method``: an int for one step, an array for arrays of steps.

    ``baumgarte``: the stabilisation terms are on (α or β non-zero); ``newton_iterations``: the
    Newton iterations of a step's dependent-coordinate solves, summed over legs; ``corrected``:
    the hybrid made a partitioned correction in that step.
    """
    if isinstance(newton_iterations, np.ndarray) or isinstance(corrected, np.ndarray):
        newton_iterations = np.asarray(newton_iterations, dtype=np.int64)
        corrected = np.asarray(corrected, dtype=np.int64)
    if method == 'partitioning':
        return (4 * EVALUATION_FLOPS + _PARTITIONED_STATES + newton_iterations * NEWTON_LEG_FLOPS
                + 5 * 6 * VELOCITY_LEG_FLOPS)
    flops = 4 * (EVALUATION_FLOPS + _DERIVATIVE) + _RK4_UPDATE + 0 * newton_iterations
    if baumgarte:
        flops += 4 * 6 * _BAUMGARTE_LEG
    if method == 'hybrid':
        flops += _DRIFT_CHECK + corrected * (newton_iterations * NEWTON_LEG_FLOPS
                                             + 6 * VELOCITY_LEG_FLOPS)
    return flops
