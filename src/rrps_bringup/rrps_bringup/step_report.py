"""A climbing step as the scripted operator sees it over ROS: its timing and its loads (pure Python; no ROS import).

:class:`ExecutionClock` sums the time executing and paused from the receipts of ``climb/status``; :class:`StepReport`
prints and checks the step: executed no faster than its plan and at most :data:`SLOWER` times it plus
:data:`SETTLE_ALLOWANCE`, peak forces within the limit and within :data:`EFFORT_AGREEMENT`, holding margin > 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rrps_interfaces.climb import ClimbPreview, ClimbState, ClimbStatus

__all__ = ['ExecutionClock', 'StepReport', 'SLOWER', 'SETTLE_ALLOWANCE', 'EFFORT_AGREEMENT', 'EARLY']

#: An executed step may take this many times its plan (on a loaded machine the robot falls behind)...
SLOWER = 2.0
#: ... plus this much [s]: the settle before each gripper and each next phase.
SETTLE_ALLOWANCE = 3.0
#: An executed step may end this much [s] before its plan: the receipt of climb/status (both ends).
EARLY = 0.2
#: The driver's measured peak force agrees with the preview's (the DAE) within this fraction.
EFFORT_AGREEMENT = 0.1


class ExecutionClock:
    """Seconds a climb spent executing and paused, from the receipt times of ``climb/status``."""

    def __init__(self):
        self.executing = self.paused = 0.0
        self._state: ClimbState | None = None
        self._since = 0.0

    def update(self, state: ClimbState, now: float) -> None:
        """A climb status in ``state`` received at ``now`` [s] (monotonic)."""
        if self._state is ClimbState.EXECUTING:
            self.executing += now - self._since
        elif self._state is ClimbState.PAUSED:
            self.paused += now - self._since
        self._state, self._since = state, now

    def reset(self) -> None:
        """Count from the next status on (the state stays known)."""
        self.executing = self.paused = 0.0


@dataclass(frozen=True)
class StepReport:
    """One executed climbing step: the climb node's ``status`` after it, its ``preview``, the
    route distance ``climbed`` [m] by ring_a, the ``executed`` and ``paused`` time [s], the
    robot's ``max_force`` [N] and the driver's ``measured_peak`` force [N] while it executed
    (None: the hardware models no loads, said in ``hardware``)."""

    status: ClimbStatus
    preview: ClimbPreview | None
    climbed: float
    executed: float
    paused: float
    max_force: float
    measured_peak: float | None
    hardware: str

    @property
    def executed_speed(self) -> float:
        """Route distance per minute of execution [m/min]."""
        return 60.0 * abs(self.climbed) / self.executed if self.executed > 0.0 else math.nan

    def lines(self) -> list[str]:
        """The result block's lines of the step."""
        s, p = self.status, self.preview
        out = [f'climbing step: {self.climbed:.3f} m in {s.step_duration:.2f} s planned '
               f'({s.climbing_speed:.2f} m/min); executed in {self.executed:.2f} s '
               f'({self.executed_speed:.2f} m/min) for {s.plan_duration:.2f} s planned'
               + (f', paused {self.paused:.1f} s' if self.paused > 0.0 else '')]
        if p is not None:
            out.append(f'climbing step peak actuator force: {p.peak_force:.1f} N (leg_{p.peak_leg}) in the '
                       f'preview, max {self.max_force:.0f} N; smallest holding margin {p.min_margin:.3f} '
                       f'({p.min_margin_ring})')
        out.append('climbing step measured peak force: ' + (
            f'{self.measured_peak:.1f} N (the driver)' if self.measured_peak is not None else
            f'not modelled (the {self.hardware} drives move kinematic axes: no load on them)'))
        return out

    def checks(self) -> list[tuple[str, bool]]:
        """Each check (module docstring) as (what, passed)."""
        s, p = self.status, self.preview
        planned = s.plan_duration
        longest = SLOWER * planned + SETTLE_ALLOWANCE
        out = [
            (f'climbing step planned: {s.step_duration:.2f} s, {s.climbing_speed:.2f} m/min',
             bool(math.isfinite(s.step_duration) and s.step_duration > 0.0 and s.climbing_speed > 0.0)),
            (f'climbing step executed at its timing: {self.executed:.2f} s for {planned:.2f} s planned '
             f'(no less, at most {longest:.1f} s)',
             bool(planned - EARLY <= self.executed and (self.paused > 0.0 or self.executed <= longest))),
        ]
        if p is None:
            return out + [('climbing step previewed', False)]
        out += [
            (f'climbing step peak actuator force {p.peak_force:.1f} N within the limit {self.max_force:.0f} N',
             bool(0.0 < p.peak_force < self.max_force)),
            (f'climbing step smallest holding margin {p.min_margin:.3f} > 0', bool(p.min_margin > 0.0)),
        ]
        if self.measured_peak is not None:
            error = abs(self.measured_peak - p.peak_force) / p.peak_force
            out.append((f"the driver's peak force {self.measured_peak:.1f} N matches the preview's "
                        f'{p.peak_force:.1f} N ({error:.1%}, at most {EFFORT_AGREEMENT:.0%})',
                        error <= EFFORT_AGREEMENT))
        return out
