"""Flop model of the dynamics (paper Figure 7's cost per step): multiply and add count one each.

The counts follow the loops of the kernels, by formula: one evaluation of eq. 19
(:func:`rrps_sim.dynamics.kernels.accelerations`), one Newton iteration of a leg's dependent
coordinates and one leg's velocity solve (:func:`rrps_sim.dynamics.integrators.solve_dependent`).
"""

from __future__ import annotations

from rrps_kinematics.multibody import FLOPS_LEG_JACOBIAN, FLOPS_LEG_RESIDUAL, FLOPS_ROTATION

__all__ = ['EVALUATION_FLOPS', 'NEWTON_LEG_FLOPS', 'VELOCITY_LEG_FLOPS', 'step_flops']

# Per leg, then once:
_LEG_BLOCKS = 13 * 3 * 3 * 5 + 700        # Φ_π' = Φ_π A for 3 bodies; vectors, crosses, γ
_LEG_SCHUR = (12 * 21                     # B W of the two links
              + 78 * 12 * 2               # D = Σ B W B^T, lower triangle
              + 12**3 // 3 + 7 * 2 * 12**2   # Cholesky of D, 7 right-hand sides
              + 36 * 12 * 2 + 6 * 12 * 2  # S and t accumulation (Woodbury)
              + 12 * 18 * 2               # Φ W F - γ
              + 12 * 6 * 2 + 18 * 12 * 2)   # λ and Φ^T λ
_BAUMGARTE_LEG = FLOPS_LEG_RESIDUAL + 12 * 18 * 2   # Φ and Φ̇ = Φ_x v
#: One evaluation of eq. 19: rotations, F^A, gyroscopic terms, six legs, the 6 x 6 ring_b solve.
EVALUATION_FLOPS = (13 * FLOPS_ROTATION + 13 * 40
                    + 6 * (_LEG_BLOCKS + _LEG_SCHUR) + 6**3 // 3 + 4 * 6**2 + 78 * 5)
#: One Newton iteration on a leg's 14 dependent coordinates: residual, Jacobian, 14 x 14 LU.
NEWTON_LEG_FLOPS = FLOPS_LEG_RESIDUAL + FLOPS_LEG_JACOBIAN + (2 * 14**3) // 3 + 2 * 14**2
#: One leg's dependent velocities from Φ_q v = 0 (eq. 20): blocks and a 12 x 12 LU.
VELOCITY_LEG_FLOPS = _LEG_BLOCKS + (2 * 12**3) // 3 + 2 * 12**2 + 12 * 6 * 2


def step_flops(method: str, baumgarte: bool, newton_iterations: int, corrected: bool) -> int:
    """Flops of one RK4 step of ``method``.

    ``baumgarte``: the stabilisation terms are on (α or β non-zero); ``newton_iterations``: the
    Newton iterations of the step's dependent-coordinate solves, summed over legs;
    ``corrected``: the hybrid made a partitioned correction.
    """
    if method == 'partitioning':
        return (4 * EVALUATION_FLOPS + newton_iterations * NEWTON_LEG_FLOPS
                + 5 * 6 * VELOCITY_LEG_FLOPS)
    flops = 4 * EVALUATION_FLOPS + 2 * (91 + 78) * 4
    if baumgarte:
        flops += 4 * 6 * _BAUMGARTE_LEG
    if method == 'hybrid':
        flops += 6 * FLOPS_LEG_RESIDUAL
        if corrected:
            flops += newton_iterations * NEWTON_LEG_FLOPS + 6 * VELOCITY_LEG_FLOPS
    return flops
