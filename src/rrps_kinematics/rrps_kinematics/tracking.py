"""Real-time direct kinematics of a stream of measured lengths: Newton seeded from the last
estimate (§2.2), guarded against assembly-mode jumps (docs/usage.md, 'The ROS interface', fk_node).

An estimate is accepted when it converged, J is not singular and det J kept its sign (assembly
modes are separated by det J = 0); a step over ``max_jump`` is re-solved by continuation from the
last accepted lengths. A refused update keeps the last good estimate. Pure NumPy, no ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.backend import interpreted, use_numba
from rrps_kinematics.forward import ForwardKinematicsResult, ForwardSolver
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.limits import limit_arrays

__all__ = ['PoseTracker', 'TrackingUpdate']


@dataclass(frozen=True)
class TrackingUpdate:
    """Outcome of one update: ``accepted``, a ``reason`` when refused, the last solve ``fk``
    and whether continuation was needed."""

    accepted: bool
    reason: str
    fk: ForwardKinematicsResult
    continuation: bool = False


class PoseTracker:
    """Warm-started FK estimate of a_T_b from measured lengths (see the module docstring)."""

    def __init__(self, geometry: RobotGeometry, *, max_jump: float = 0.05, continuation_steps: int = 20,
                 tolerance: float = 1e-12, max_iterations: int = 30):
        if not max_jump >= 0.0:
            raise ValueError(f'max_jump must be >= 0, got {max_jump}')
        if continuation_steps < 1:
            raise ValueError(f'continuation_steps must be >= 1, got {continuation_steps}')
        self.geometry = geometry
        self.max_jump = float(max_jump)
        self.continuation_steps = int(continuation_steps)
        self._solver = ForwardSolver(geometry, tolerance=tolerance, max_iterations=max_iterations)
        self.reset(geometry.home_position, geometry.home_quaternion_xyzw)

    @property
    def tolerance(self) -> float:
        return self._solver.tolerance

    @tolerance.setter
    def tolerance(self, value: float) -> None:
        self._solver = ForwardSolver(self.geometry, tolerance=value, max_iterations=self.max_iterations)

    @property
    def max_iterations(self) -> int:
        return self._solver.max_iterations

    @max_iterations.setter
    def max_iterations(self, value: int) -> None:
        self._solver = ForwardSolver(self.geometry, tolerance=self.tolerance, max_iterations=value)

    def reset(self, position, quaternion_xyzw) -> None:
        """Start again from a known pose (its lengths and assembly mode become the reference)."""
        self.position = np.array(position, dtype=float)
        self.quaternion_xyzw = np.array(quaternion_xyzw, dtype=float)
        self.lengths = inverse_kinematics(self.geometry, self.position, self.quaternion_xyzw).lengths
        self.det_sign = self.jacobian_sign(self.position, self.quaternion_xyzw)

    def jacobian_sign(self, position, quaternion_xyzw) -> float:
        """Sign of det J at a pose: +1 or -1 in an assembly mode's region, 0 when singular."""
        from rrps_kinematics.compiled_limits import jacobian_determinant
        p = np.ascontiguousarray(position, dtype=float)
        q = np.ascontiguousarray(quaternion_xyzw, dtype=float)
        if use_numba('auto'):
            return float(np.sign(jacobian_determinant(limit_arrays(self.geometry), p, q)))
        return float(np.sign(interpreted(jacobian_determinant)(limit_arrays(self.geometry, lists=True),
                                                               p.tolist(), q.tolist())))

    def distance(self, position, quaternion_xyzw) -> float:
        """Translation plus rotation angle times the characteristic length, from the estimate [m]."""
        q1 = np.asarray(quaternion_xyzw, dtype=float)
        q2 = self.quaternion_xyzw if np.dot(q1, self.quaternion_xyzw) >= 0.0 else -self.quaternion_xyzw
        # rotation angle = 2 x the angle between the unit quaternions, robust near 0 and pi
        angle = 4.0 * math.atan2(np.linalg.norm(q1 - q2), np.linalg.norm(q1 + q2))
        return (float(np.linalg.norm(np.asarray(position) - self.position))
                + self.geometry.characteristic_length * float(angle))

    def _solve(self, lengths, position, quaternion_xyzw) -> ForwardKinematicsResult:
        return self._solver(lengths, position, quaternion_xyzw)

    def _failed(self, fk: ForwardKinematicsResult) -> str:
        if fk.converged and not fk.singular:
            return ''
        return (f'no convergence (residual {fk.residual:.3g} m after {fk.iterations} iterations'
                f'{", singular Jacobian" if fk.singular else ""})')

    def update(self, lengths) -> TrackingUpdate:
        """Solve for new measured lengths (6,); accept or keep the last estimate. ValueError
        for NaN/inf or a wrong shape (as forward_kinematics)."""
        L = np.asarray(lengths, dtype=float)
        fk = self._solve(L, self.position, self.quaternion_xyzw)
        reason = self._failed(fk)
        if reason:
            return TrackingUpdate(False, reason, fk)
        continuation = self.max_jump > 0.0 and self.distance(fk.position, fk.quaternion_xyzw) > self.max_jump
        if continuation:
            p, q = self.position, self.quaternion_xyzw
            for s in np.linspace(0.0, 1.0, self.continuation_steps + 1)[1:]:
                fk = self._solve(self.lengths + s * (L - self.lengths), p, q)
                reason = self._failed(fk)
                if reason:
                    return TrackingUpdate(False, f'large step ({reason} on the continuation path at '
                                                 f'{s:.2f}): another assembly mode?', fk, True)
                p, q = fk.position, fk.quaternion_xyzw
        sign = self.jacobian_sign(fk.position, fk.quaternion_xyzw)
        if sign != self.det_sign:
            return TrackingUpdate(False, 'det(J) changed sign: the solution crossed a singularity '
                                         'or switched assembly mode', fk, continuation)
        self.position, self.quaternion_xyzw, self.lengths = fk.position, fk.quaternion_xyzw, L
        return TrackingUpdate(True, '', fk, continuation)
