"""Time-optimal, jerk-limited timing of a planned motion along its path (TOPP-RA, Pham and Pham,
IEEE T-RO 2018).

The law s(t) satisfies :mod:`.timing_constraints` (the legs' limits, a speed cap, forces and
holding by eq. 19), is made jerk-limited by :mod:`.timing_profile`, checked every
:data:`SAMPLE_PERIOD`, and slowed uniformly where a check fails; a motion no speed realises is refused::

    timed = time_motion(geometry, path, ring_angles, held=Held('ring_a', q, g), where=(1, 'move_b'))
    timed.duration, timed.loads.actuator_forces, timed.at(t)
"""

from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np
import toppra
from toppra.constraint import DiscretizationType, LinearConstraint

from rrps_climbing.path_curve import PathCurve, corner_pieces
from rrps_climbing.phase_path import PhasePath
from rrps_climbing.plan import PlanError, PlanLimit
from rrps_climbing.timing_constraints import GridLimits, Held, grid_limits
from rrps_climbing.timing_profile import SmoothedLaw, TimingLaw, jerk_window
from rrps_description.geometry import RobotGeometry
from rrps_description.motion_limits import ActuatorLimits, stream_limits
from rrps_description.pose import Pose
from rrps_loads.loads import holding_margin
from rrps_loads.path_loads import loads_at, min_margin, peak_force, peak_leg

__all__ = ['SAMPLE_PERIOD', 'GRID_SPACING', 'TimedLoads', 'TimedMotion', 'time_motion', 'rest_loads',
           'check_speed']

#: The timed motion's samples [s]: the driver's period.
SAMPLE_PERIOD = 0.002
#: The largest distance [m] between TOPP-RA's gridpoints along the path parameter.
GRID_SPACING = 0.005
#: The fewest TOPP-RA stages of a motion.
MIN_STAGES = 16
#: How much each retry slows a law whose loads exceed a limit.
SLOWER = 1.03
MAX_RETRIES = 60

logging.getLogger('toppra').setLevel(logging.ERROR)   # its failures are raised here, with where


class TimedLoads(NamedTuple):
    """The loads of a timed motion at its samples: ``actuator_forces`` (K, 6) [N], the holding
    ring's ``support_wrench`` (K, 6) and ``holding_margin`` (K,) (NaN without a capacity)."""

    ring: str
    actuator_forces: np.ndarray
    support_wrench: np.ndarray
    holding_margin: np.ndarray

    @property
    def peak_force(self) -> float:
        return peak_force(self.actuator_forces)

    @property
    def peak_leg(self) -> int:
        return peak_leg(self.actuator_forces)

    @property
    def min_holding_margin(self) -> float:
        return min_margin(self.holding_margin)


class TimedMotion:
    """A motion's path with its timing law (module docstring): its ``pieces`` between corners, each
    a :class:`~.path_curve.PathCurve` and its :class:`~.timing_profile.SmoothedLaw` from rest to
    rest, one after the other; the loads at the samples (None when no ring was given as holding),
    the requested path-speed cap and the peak path speed reached [m/s]; the legs' stream limits it
    was timed within (a paused stream brakes within them, :mod:`.path_brake`)."""

    def __init__(self, pieces: list, loads: TimedLoads | None, requested_speed: float | None, peak_speed: float,
                 leg_limits: ActuatorLimits):
        self.pieces, self.loads = pieces, loads
        self.requested_speed, self.peak_speed = requested_speed, peak_speed
        self.leg_limits = leg_limits
        self._starts = np.concatenate([[0.0], np.cumsum([law.duration for _, law in pieces])])
        #: the times [s] of the samples of ``loads`` (each piece's from its start, a little past its end)
        self.load_times = np.zeros(0)

    @property
    def starts(self) -> np.ndarray:
        """When each piece starts [s]."""
        return self._starts[:-1]

    @property
    def duration(self) -> float:
        """How long the motion takes [s]."""
        return float(self._starts[-1])

    @property
    def capped(self) -> bool:
        """A path speed was requested that the legs' limits do not reach anywhere on the path."""
        return self.requested_speed is not None and self.peak_speed < 0.999 * self.requested_speed

    def sample_times(self, period: float = SAMPLE_PERIOD) -> np.ndarray:
        """0, period, 2 period, ... up to and including the end."""
        n = max(1, math.ceil(self.duration / period - 1e-9))
        return np.minimum(np.arange(n + 1) * period, self.duration)

    def poses(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions (K, 3), quaternions (K, 4) and ring angles (K, 2) at times ``t`` (K,)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        piece = np.clip(np.searchsorted(self._starts, t, side='right') - 1, 0, len(self.pieces) - 1)
        p, q, angles = np.zeros((len(t), 3)), np.zeros((len(t), 4)), np.zeros((len(t), 2))
        for i, (curve, law) in enumerate(self.pieces):
            here = piece == i
            if np.any(here):
                s = law.evaluate(t[here] - self._starts[i])[0]
                (p[here], q[here]), angles[here] = curve.poses(s), curve.ring_angles(s)
        return p, q, angles

    def at(self, t: float) -> tuple[Pose, np.ndarray]:
        """The timed a_T_b and ring angles (theta_a, theta_b) at time ``t`` [s] of the motion."""
        p, q, angles = self.poses([t])
        return Pose(p[0], q[0]), angles[0]

    def phase_path(self, period: float = SAMPLE_PERIOD) -> PhasePath:
        """The motion sampled every ``period`` [s], as a stream plays it."""
        t = self.sample_times(period)
        return PhasePath(t, *self.poses(t))


class _Arrays(LinearConstraint):
    """TOPP-RA's canonical linear constraint from precomputed arrays (``v = a u + b x + c``,
    ``v <= g``, ``x <= x_max``), interpolation discretization."""

    def __init__(self, limits: GridLimits):
        super().__init__()
        self.limits = limits
        self.identical = True
        self.discretization_type = DiscretizationType.Interpolation

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
        k = self.limits
        xbound = np.column_stack([np.zeros_like(k.x_max), k.x_max])
        return k.a, k.b, k.c, np.eye(k.a.shape[1]), k.g, None, xbound


class _Interval(toppra.interpolator.AbstractGeometricPath):
    """The path's interval for TOPP-RA (the constraints hold the geometry)."""

    def __init__(self, length: float):
        self.length = length

    @property
    def path_interval(self) -> np.ndarray:
        return np.array([0.0, self.length])

    @property
    def dof(self) -> int:
        return 1

    @property
    def waypoints(self):
        return None

    def __call__(self, path_positions, order: int = 0) -> np.ndarray:
        return np.zeros((np.size(path_positions), 1))


def check_speed(speed, step, phase) -> float | None:
    """A requested path-speed cap [m/s] (None: none); PlanError (limit SPEED) naming the step
    and phase unless it is finite and > 0."""
    if speed is None:
        return None
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not (math.isfinite(speed) and speed > 0.0):
        raise PlanError(f'speed: {speed!r} m/s requested for step {step} {phase}: must be a finite number > 0',
                        limit=PlanLimit.SPEED, step=step, phase=phase)
    return float(speed)


def _unrealisable(limits: GridLimits, where: tuple) -> PlanError:
    """Why TOPP-RA found no timing: a limit broken at rest (the first row), else the path."""
    step, phase = where
    over = limits.c - limits.g > 1e-9
    if np.any(over):
        i, row = (int(v[0]) for v in np.nonzero(over))
        kind, who = limits.rows[row]
        fraction = float(limits.s[i] / limits.s[-1]) if limits.s[-1] > 0 else 0.0
        return PlanError(f'{kind}, {who}, step {step} {phase}, fraction {fraction:.2f} of the path: '
                         f'beyond its limit even at rest', limit=PlanLimit(kind),
                         legs=(who,) if who.startswith('leg') else (), ring=None if who.startswith('leg') else who,
                         step=step, phase=phase, fraction=fraction)
    return PlanError(f'timing, step {step} {phase}: no timing of the path within the legs\' speed, acceleration '
                     'and force limits and the holding capacity', limit=PlanLimit.TIMING, step=step, phase=phase)


def _topp(limits: GridLimits, length: float, where: tuple) -> np.ndarray:
    """The path speeds ṡ at the gridpoints of the time-optimal rest-to-rest law."""
    algorithm = toppra.algorithm.TOPPRA([_Arrays(limits)], _Interval(length), gridpoints=limits.s,
                                        solver_wrapper='seidel')
    result = algorithm.compute_parameterization(0.0, 0.0)
    sd = None if result is None else result[1]
    if sd is None or not np.all(np.isfinite(sd)):
        raise _unrealisable(limits, where)
    return np.asarray(sd, dtype=float)


class _Excess(NamedTuple):
    """How far a sampled law goes past its limits: the ratios of the legs' speed, acceleration
    and jerk to theirs, and the first sample past a load limit (None: none)."""

    speed: float
    acceleration: float
    jerk: float
    load: tuple | None


def _loads(geometry, limits: GridLimits, held: Held, s, u, x) -> TimedLoads:
    forces, wrench = limits.loads.at(limits.s, s, u, x)
    capacity = geometry.holding.get(held.ring)
    margin = np.full(len(s), np.nan) if capacity is None else holding_margin(capacity, wrench)
    return TimedLoads(held.ring, forces, wrench, margin)


def _sample_times(law: SmoothedLaw) -> np.ndarray:
    """Where a piece's law is checked: every SAMPLE_PERIOD from 0 past its end."""
    return np.arange(max(2, math.ceil(law.duration / SAMPLE_PERIOD) + 1)) * SAMPLE_PERIOD


def _check(geometry, curve, limits, legs, law: SmoothedLaw, held) -> tuple[_Excess, TimedLoads | None, np.ndarray]:
    t = _sample_times(law)
    s, sd, sdd = law.evaluate(t)
    _, L1, L2 = curve.leg_rates(geometry, s)
    v, a = L1 * sd[:, None], L1 * sdd[:, None] + L2 * sd[:, None] ** 2
    jerk = np.max(np.abs(np.diff(a, axis=0))) / SAMPLE_PERIOD
    loads, load = None, None
    if held is not None:
        loads = _loads(geometry, limits, held, s, sdd, sd ** 2)
        bad = np.flatnonzero(np.any(np.abs(loads.actuator_forces) > geometry.max_force, axis=1)
                             | (loads.holding_margin < 0.0))
        load = (int(bad[0]), t[bad[0]]) if bad.size else None
    return (_Excess(np.max(np.abs(v)) / legs.speed, np.max(np.abs(a)) / legs.acceleration, jerk / legs.jerk, load),
            loads, sd)


def _refusal(geometry, loads: TimedLoads, k: int, fraction: float, at: str, where: tuple) -> PlanError:
    """The PlanError of sample ``k`` of ``loads`` past a limit at any speed."""
    step, phase = where
    f = np.abs(loads.actuator_forces[k])
    at = f'step {step} {phase}, fraction {fraction:.2f} of the motion ({at})'
    if np.any(f > geometry.max_force):
        leg = int(np.argmax(f))
        return PlanError(f'actuator_force, leg_{leg + 1}, {at}: {loads.actuator_forces[k, leg]:.1f} N exceeds the '
                         f'actuator limit {geometry.max_force:.1f} N however slowly it moves',
                         limit=PlanLimit.ACTUATOR_FORCE, legs=(f'leg_{leg + 1}',), step=step, phase=phase,
                         fraction=fraction)
    return PlanError(f'holding, {loads.ring}, {at}: holding margin {loads.holding_margin[k]:.3f} < 0 however slowly '
                     'it moves: the gripper slips', limit=PlanLimit.HOLDING, ring=loads.ring, step=step, phase=phase,
                     fraction=fraction, margins={'holding': float(loads.holding_margin[k])})


def _check_rest(geometry, limits: GridLimits, held: Held, where: tuple) -> None:
    """Refuse a path whose loads at rest already break a limit somewhere (no timing helps)."""
    zero = np.zeros(len(limits.s))
    rest = _loads(geometry, limits, held, limits.s, zero, zero)
    over = np.any(np.abs(rest.actuator_forces) > geometry.max_force, axis=1)
    bad = np.flatnonzero(over | (rest.holding_margin < 0.0))
    if bad.size:
        k = int(bad[0])
        raise _refusal(geometry, rest, k, float(limits.s[k] / limits.s[-1]), 'at rest', where)


def _time_piece(geometry: RobotGeometry, curve: PathCurve, legs: ActuatorLimits, speed, held, where):
    """(law, loads, peak path speed) of one piece from rest to rest (module docstring)."""
    s = np.linspace(0.0, curve.length, max(MIN_STAGES, math.ceil(curve.length / GRID_SPACING)) + 1)
    limits = grid_limits(geometry, curve, s, speed=legs.speed, acceleration=legs.acceleration, speed_cap=speed,
                         held=held)
    if held is not None:
        _check_rest(geometry, limits, held, where)
    law = TimingLaw(s, _topp(limits, curve.length, where))
    path_jerk = legs.jerk / max(float(np.max(np.abs(limits.L1))), 1e-12)
    smoothed = SmoothedLaw(law, jerk_window(law, path_jerk))
    for _ in range(MAX_RETRIES):
        excess, loads, sd = _check(geometry, curve, limits, legs, smoothed, held)
        scale = max(excess.speed, math.sqrt(excess.acceleration), excess.jerk ** (1.0 / 3.0))
        if scale > 1.0 + 1e-6:
            smoothed = SmoothedLaw(law, smoothed.window, smoothed.scale * scale * (1.0 + 1e-6))
        elif excess.load is not None:
            smoothed = SmoothedLaw(law, smoothed.window, smoothed.scale * SLOWER)
        else:
            return smoothed, loads, float(np.max(sd))
    k, t = excess.load
    raise _refusal(geometry, loads, k, t / smoothed.duration, f't={t:.2f} s', where)


def time_motion(geometry: RobotGeometry, path: np.ndarray, ring_angles: np.ndarray, *, speed: float | None = None,
                held: Held | None = None, where: tuple = (0, 'move')) -> TimedMotion:
    """The time-optimal, jerk-limited timing of a sampled path (n, 4, 4) with its ring angles
    (n, 2) (module docstring): from rest to rest between its corners
    (:func:`~.path_curve.corner_pieces`), within the legs' limits
    (:attr:`RobotGeometry.motion_limits`, their :func:`stream_limits`), the path-speed cap
    ``speed`` [m/s] (None: none) and, with ``held``, the force limit and the holding ring's
    capacity. ``where`` (step, phase) names the motion in a refusal (:class:`PlanError`)."""
    speed = check_speed(speed, *where)
    legs = stream_limits(geometry.motion_limits.legs)
    c = geometry.characteristic_length
    pieces, loads, peak = [], [], 0.0
    for piece in corner_pieces(path, c):
        curve = PathCurve(path[piece], ring_angles[piece], characteristic_length=c)
        if curve.length <= 0.0:
            continue
        law, piece_loads, piece_peak = _time_piece(geometry, curve, legs, speed, held, where)
        pieces.append((curve, law))
        loads.append(piece_loads)
        peak = max(peak, piece_peak)
    if not pieces:
        raise ValueError(f'step {where[0]} {where[1]}: the path has no length to time')
    joined = None if held is None else TimedLoads(held.ring, *(np.concatenate([x[k] for x in loads])
                                                              for k in (1, 2, 3)))
    timed = TimedMotion(pieces, joined, speed, peak, legs)
    timed.load_times = np.concatenate([start + _sample_times(law) for start, (_, law) in zip(timed.starts, pieces)])
    return timed


def rest_loads(geometry: RobotGeometry, a_T_b: Pose, held: Held, where: tuple) -> TimedLoads:
    """The loads of the robot resting at ``a_T_b`` on one gripper (a release); PlanError when they
    break a limit."""
    zero = np.zeros((1, 6))
    x = loads_at(geometry, a_T_b.position[None], a_T_b.quaternion_xyzw[None], zero, zero, support=held.ring,
                 world_q_support=held.world_q, gravity=held.gravity)
    loads = TimedLoads(held.ring, x.actuator_forces, x.support_wrench, x.holding_margin)
    if np.any(np.abs(loads.actuator_forces) > geometry.max_force) or loads.holding_margin[0] < 0.0:
        raise _refusal(geometry, loads, 0, 0.0, 'at rest', where)
    return loads
