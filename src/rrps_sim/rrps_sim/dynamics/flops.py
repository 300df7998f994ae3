"""Flop model of the dynamics (Figure 7's cost per step): multiply, add, divide and square root
count one each, by formula from the kernels' loops.
"""

from __future__ import annotations

import numpy as np

from rrps_kinematics.multibody import FLOPS_LEG_JACOBIAN, FLOPS_LEG_RESIDUAL, FLOPS_ROTATION

__all__ = ['EVALUATION_FLOPS', 'NEWTON_LEG_FLOPS', 'VELOCITY_LEG_FLOPS', 'evaluation_flops', 'step_flops']

# One leg of an evaluation of eq. 19, with m rows coupling the leg to the hub (3 or 4):
_LEG_BLOCKS = 13 * 3 * 3 * 5 + 700        # [Φ_r Φ_π'] and γ: Φ_π' = Φ_π A, vectors, crosses


def _leg_solve(n: int) -> int:
    """B_l Y = R for n right-hand sides: K's rows 9-10 with the translations eliminated, the
    6 x (6 + n) elimination, back substitution and translations."""
    return (2 * 3 * 12 + 18 * n + sum(1 + (5 - j) * (1 + 2 * (5 + n - j)) for j in range(6))
            + 72 * n)


def _leg_coupling(m: int) -> int:
    """M_l [H | c]; Λ = H^T M_l H and w (12 rows); Λ P_r (4 x 3); S += P^T Λ P, t -= P^T w;
    P a_h and a_l = c - H P a_h."""
    return (36 * (m + 1) + 12 * (m * (m + 1) + 1 + 2 * m) + 84 + 3 * 9 + 9 * 11 + 7 * m
            + 12 * 2 * m)


def evaluation_flops(support: int = 0) -> int:
    """One evaluation of eq. 19 with ring_a (0) or ring_b (1) grounded: 13 rotations, F^A, the
    gyroscopic terms and the tool wrench, six legs (12: the actuator force on both links), the
    hub's 6 x 6 Cholesky factorisation (91) and solve (72)."""
    m = 3 + support
    return 13 * FLOPS_ROTATION + 13 * 27 + 60 + 6 * (_LEG_BLOCKS + 12 + _leg_solve(m + 1) + _leg_coupling(m)) + 91 + 72


#: Per leg and evaluation with Baumgarte terms: Φ (rotations given), Φ̇ = Φ_x v, γ update.
_BAUMGARTE_LEG = FLOPS_LEG_RESIDUAL - 2 * FLOPS_ROTATION + 12 * 18 * 2 + 12 * 6
#: One evaluation of eq. 19 with ring_a grounded (the paper's case).
EVALUATION_FLOPS = evaluation_flops(0)
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


def step_flops(method: str, baumgarte: bool, newton_iterations, corrected, support: int = 0):
    """Flops of RK4 steps of ``method`` with ring_a (``support`` 0) or ring_b (1) grounded: an int for
    one step, an array for arrays of steps (``newton_iterations``, ``corrected`` per step)."""
    if isinstance(newton_iterations, np.ndarray) or isinstance(corrected, np.ndarray):
        newton_iterations = np.asarray(newton_iterations, dtype=np.int64)
        corrected = np.asarray(corrected, dtype=np.int64)
    evaluation = evaluation_flops(support)
    if method == 'partitioning':
        return (4 * evaluation + _PARTITIONED_STATES + newton_iterations * NEWTON_LEG_FLOPS
                + 5 * 6 * VELOCITY_LEG_FLOPS)
    flops = 4 * (evaluation + _DERIVATIVE) + _RK4_UPDATE + 0 * newton_iterations
    if baumgarte:
        flops += 4 * 6 * _BAUMGARTE_LEG
    if method == 'hybrid':
        flops += _DRIFT_CHECK + corrected * (newton_iterations * NEWTON_LEG_FLOPS
                                             + 6 * VELOCITY_LEG_FLOPS)
    return flops
