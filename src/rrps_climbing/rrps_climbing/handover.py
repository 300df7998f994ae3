"""Loads of a hand-over: both grippers hold the resting robot, which is statically indeterminate.

Any structure wrenches with w_a + X w_b = w_a⁰ balance it, X (f, m) = (R f, R m + p × R f)
(w_a⁰: ring_a alone holding, :func:`rrps_loads.loads.static_solution`). The split taken is the
minimum-norm one (moments weighted by 1 / characteristic length), that of two equally stiff grips;
both rings' holding and the forces against ``max_force`` are checked. No ROS import.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rrps_climbing.plan import Phase, PhaseLoads, PlanError, PlanLimit
from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_kinematics import inverse_kinematics
from rrps_kinematics.jacobian import leg_forces
from rrps_loads.loads import holding_margin, static_solution

__all__ = ['HandoverLoads', 'handover_loads', 'check_handover']


class HandoverLoads(NamedTuple):
    """The minimum-norm split: actuator ``forces`` (6,) [N], each ring's structure wrench (6,)
    (its frame, about its origin) and holding margin (NaN without a capacity)."""

    forces: np.ndarray
    wrench_a: np.ndarray
    wrench_b: np.ndarray
    margin_a: float
    margin_b: float


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def handover_loads(geometry: RobotGeometry, a_T_b: Pose, world_q_a, gravity) -> HandoverLoads:
    """The loads of the robot resting at ``a_T_b`` held by both rings, ring_a at attitude
    ``world_q_a`` in a world of ``gravity`` (module docstring)."""
    alone = static_solution(geometry, a_T_b, support='ring_a', world_q_support=world_q_a, gravity=gravity)
    R, p = a_T_b.rotation, a_T_b.position
    X = np.zeros((6, 6))
    X[:3, :3] = X[3:, 3:] = R
    X[3:, :3] = _skew(p) @ R
    S2 = np.diag([1.0] * 3 + [geometry.characteristic_length ** -2] * 3)
    w_b = np.linalg.solve(X.T @ S2 @ X + S2, X.T @ S2 @ alone.support_wrench)
    w_a = alone.support_wrench - X @ w_b
    ik = inverse_kinematics(geometry, p, a_T_b.quaternion_xyzw)
    forces = alone.actuator_forces + leg_forces(ik, np.concatenate([R @ w_b[:3], R @ w_b[3:]]))
    margins = [float(holding_margin(geometry.holding[ring], w)) if ring in geometry.holding else math.nan
               for ring, w in (('ring_a', w_a), ('ring_b', w_b))]
    return HandoverLoads(np.asarray(forces, dtype=float), w_a, w_b, *margins)


def check_handover(geometry: RobotGeometry, ph: Phase, world_q_a, gravity) -> PhaseLoads:
    """The :class:`PhaseLoads` of a hand-over phase (both grippers closed); PlanError when an
    actuator force or either ring's holding margin is past its limit."""
    loads = handover_loads(geometry, ph.a_T_b, world_q_a, gravity)
    where = f'step {ph.step} {ph.phase} (hand-over, both grippers hold; minimum-norm split)'
    f = np.abs(loads.forces)
    leg = int(np.argmax(f))
    if f[leg] > geometry.max_force:
        raise PlanError(f'actuator_force, leg_{leg + 1}, {where}: {loads.forces[leg]:.1f} N exceeds the actuator '
                        f'limit {geometry.max_force:.1f} N', limit=PlanLimit.ACTUATOR_FORCE, legs=(f'leg_{leg + 1}',),
                        step=ph.step, phase=ph.phase)
    margins = {'ring_a': loads.margin_a, 'ring_b': loads.margin_b}
    for ring, margin in margins.items():
        if margin < 0.0:
            raise PlanError(f'holding, {ring}, {where}: holding margin {margin:.3f} < 0: the gripper slips',
                            limit=PlanLimit.HOLDING, ring=ring, step=ph.step, phase=ph.phase,
                            margins={'holding': margin})
    held = {ring: m for ring, m in margins.items() if not math.isnan(m)}
    ring = min(held, key=held.get) if held else 'ring_a'
    return PhaseLoads(peak_force=float(f[leg]), peak_leg=f'leg_{leg + 1}', holding_margin=held.get(ring, math.nan),
                      holding_ring=ring)
