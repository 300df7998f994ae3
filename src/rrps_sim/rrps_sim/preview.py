"""Preview of a planned climbing step on the 13-body DAE (eqs. 19-20): the peak loads before it runs.

Each motion (:class:`PreviewMotion`) starts at rest on its own supporting ring, in the world's
gravity with the robot's payload and tool wrench; the legs are driven as the driver's dynamic
mode drives them (:mod:`rrps_sim.dynamics.driven`). The multipliers of eq. 19 give the support's
wrench and holding margin (:mod:`rrps_loads.loads`); see docs/architecture.md, 'rrps_sim'.
Pure NumPy (and the compiled dynamics); no ROS import.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, NamedTuple, Sequence

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_hardware.setpoints import DRIVER_PERIOD, stream_setpoints
from rrps_interfaces.climb import PreviewLimit
from rrps_kinematics.inverse import inverse_kinematics
from rrps_loads.loads import holding_margin, support_wrench
from rrps_loads.statics import holding_forces
from rrps_loads.support import support_of
from rrps_sim.dynamics import MultibodyDynamics
from rrps_sim.dynamics.driven import DriveLoop

__all__ = ['Drives', 'PreviewMotion', 'PreviewResult', 'PreviewError', 'preview_step']


class PreviewError(RuntimeError):
    """The preview could not simulate the step (a singular configuration on the way, or a
    dependent-coordinate solve that did not converge)."""


class Drives(NamedTuple):
    """The legs' drives as the driver's dynamic mode models them (its parameters' defaults):
    PD gains ``kp`` [N/m], ``kd`` [N s/m], the reference's lag ``time_constant`` [s] and
    ``max_speed`` [m/s] (None: the robot's), the gravity feed-forward's refresh period [s], and
    whether the commands pass the driver's jerk-limited setpoints (``jerk_limited``)."""

    kp: float = 1.0e5
    kd: float = 1.0e3
    time_constant: float = 0.02
    max_speed: float | None = None
    feedforward_period: float = 0.02
    jerk_limited: bool = True


@dataclass(frozen=True)
class PreviewMotion:
    """One motion of a step: ``name`` (where, for reports: 'step 1 move_b'), the ``support`` ring
    that holds meanwhile and its attitude ``world_q_support`` (x, y, z, w) in the world, and the
    commanded poses a_T_b: ``positions`` (n, 3) [m], ``quaternions`` (n, 4), one every
    ``period`` s."""

    name: str
    support: str
    world_q_support: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    period: float

    @property
    def duration(self) -> float:
        """The time its commands take [s] (without the hold after them)."""
        return self.period * (len(self.positions) - 1)


@dataclass(frozen=True)
class PreviewResult:
    """The peaks over a previewed step: the largest asked drive force [N] (leg 1..6, time), the largest
    structure's wrench on a supporting ring [N, N m], the smallest holding margin (NaN without a
    gripper capacity), the first limit broken (None: none) with its ``detail``, and the times [s]."""

    peak_force: float
    peak_leg: int
    peak_force_at: str
    max_force: float
    peak_reaction_force: float
    peak_reaction_moment: float
    min_margin: float
    min_margin_ring: str
    min_margin_at: str
    limit: PreviewLimit | None
    detail: str
    simulated: float
    wall: float

    @property
    def accepted(self) -> bool:
        """No limit broken."""
        return self.limit is None

    @property
    def speed(self) -> float:
        """Simulated over wall time: how many times faster than real time."""
        return self.simulated / self.wall if self.wall > 0.0 else math.inf


class _Peaks:
    """The running peaks of a preview."""

    def __init__(self):
        self.force, self.leg, self.force_at = 0.0, 0, ''
        self.reaction_force = self.reaction_moment = 0.0
        self.margin, self.margin_ring, self.margin_at = math.nan, '', ''

    def forces(self, demand: np.ndarray, where: str) -> None:
        k = int(np.argmax(np.abs(demand)))
        if abs(demand[k]) > self.force:
            self.force, self.leg, self.force_at = float(abs(demand[k])), k + 1, where

    def wrench(self, wrench: np.ndarray, margin: float, ring: str, where: str) -> None:
        self.reaction_force = max(self.reaction_force, float(np.linalg.norm(wrench[:3])))
        self.reaction_moment = max(self.reaction_moment, float(np.linalg.norm(wrench[3:])))
        if math.isfinite(margin) and not margin >= self.margin:
            self.margin, self.margin_ring, self.margin_at = float(margin), ring, where


def preview_step(geometry: RobotGeometry, motions: Sequence[PreviewMotion], *, gravity=None,
                 drives: Drives = Drives(), dt: float = 0.001, settle: float = 0.2,
                 min_margin: float = 0.0, correction_tolerance: float = 1e-8,
                 cancelled: Callable[[], bool] | None = None) -> PreviewResult:
    """Simulate a step's ``motions`` (steps of ``dt`` [s]) and return their peaks; a limit is broken past
    ``max_force`` or below ``min_margin``. ``cancelled()`` is polled between batches. Raises ValueError
    for invalid input, PreviewError when the dynamics fails or the preview is cancelled."""
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f'dt must be a positive number of seconds, got {dt!r}')
    if not (math.isfinite(settle) and settle >= 0.0):
        raise ValueError(f'settle must be >= 0 s, got {settle!r}')
    if not motions:
        raise ValueError('a preview needs at least one motion')
    start = time.perf_counter()
    peaks = _Peaks()
    simulated = 0.0
    for motion in motions:
        simulated += _simulate_motion(geometry, motion, gravity, drives, dt, settle,
                                      correction_tolerance, peaks, cancelled)
    limit, detail = _verdict(geometry, peaks, min_margin)
    return PreviewResult(peak_force=peaks.force, peak_leg=peaks.leg, peak_force_at=peaks.force_at,
                         max_force=float(geometry.max_force),
                         peak_reaction_force=peaks.reaction_force,
                         peak_reaction_moment=peaks.reaction_moment, min_margin=peaks.margin,
                         min_margin_ring=peaks.margin_ring, min_margin_at=peaks.margin_at,
                         limit=limit, detail=detail, simulated=simulated,
                         wall=time.perf_counter() - start)


def _verdict(geometry: RobotGeometry, peaks: _Peaks, min_margin: float) -> tuple[PreviewLimit | None, str]:
    if peaks.force > geometry.max_force:
        return PreviewLimit.ACTUATOR_FORCE, (
            f'actuator force: leg_{peaks.leg} needs {peaks.force:.1f} N > {geometry.max_force:g} N '
            f'at {peaks.force_at}')
    if peaks.margin < min_margin:
        return PreviewLimit.HOLDING, (
            f'holding: {peaks.margin_ring} margin {peaks.margin:.3f} < {min_margin:g} at {peaks.margin_at}')
    margin = 'no holding capacity given' if math.isnan(peaks.margin) else \
        f'smallest holding margin {peaks.margin:.3f} ({peaks.margin_ring})'
    return None, f'peak force {peaks.force:.1f} N (leg_{peaks.leg}), {margin}'


def _motion_arrays(geometry: RobotGeometry, motion: PreviewMotion) -> tuple[np.ndarray, np.ndarray]:
    """The motion's poses checked, and its commanded lengths (n, 6) by IK."""
    p = np.asarray(motion.positions, dtype=float)
    q = np.asarray(motion.quaternions, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or q.shape != (len(p), 4) or len(p) < 1:
        raise ValueError(f'{motion.name}: positions (n, 3) and quaternions (n, 4) expected, '
                         f'got {p.shape}, {q.shape}')
    if not (math.isfinite(motion.period) and motion.period > 0.0):
        raise ValueError(f'{motion.name}: period must be > 0 s, got {motion.period!r}')
    return p, inverse_kinematics(geometry, p, q).lengths


def _simulate_motion(geometry, motion, gravity, drives, dt, settle, correction_tolerance,
                     peaks: _Peaks, cancelled) -> float:
    """One motion from rest on its support, in batches of the feed-forward's period; returns the
    time simulated [s]."""
    positions, commands = _motion_arrays(geometry, motion)
    quaternions = np.asarray(motion.quaternions, dtype=float)
    support = support_of(motion.support, motion.world_q_support, gravity)
    capacity = geometry.holding.get(support.ring)
    dyn = MultibodyDynamics(geometry, 'hybrid', support=support, correction_tolerance=correction_tolerance)
    try:
        dyn.reset(positions[0], quaternions[0])
        # the gravity feed-forward of each command (the driver's, at the pose it measures)
        feedforward = holding_forces(geometry, positions, quaternions, support=support)
    except (ValueError, RuntimeError) as exc:
        raise PreviewError(f'{motion.name}: the commanded poses are not held at rest ({exc})') from None
    drive = _drive_loop(geometry, drives)
    period = motion.period
    if drives.jerk_limited:   # the driver's setpoints, every driver period, through the hold after
        commands = stream_setpoints(commands, motion.period, geometry.motion_limits.legs, settle=settle)
        period = DRIVER_PERIOD
    reference = np.concatenate([dyn.lengths, np.zeros(6)])
    forces, peak = feedforward[0].copy(), np.zeros(6)
    n_steps = max(1, math.ceil((motion.duration + settle) / dt - 1e-9))
    batch = max(1, round(drives.feedforward_period / dt)) if drives.feedforward_period > 0 else n_steps
    done = 0
    while done < n_steps:
        t = done * dt
        where = f'{motion.name}, t={t:.2f} s'
        _sample_wrench(geometry, dyn, support, capacity, forces, peaks, where)
        if cancelled is not None and cancelled():
            raise PreviewError('preview cancelled')
        steps = min(batch, n_steps - done)
        ff = feedforward[min(int(t / motion.period + 1e-9), len(feedforward) - 1)]
        before = peak.copy()
        try:
            dyn.run_driven(commands, period, t, steps, dt, drive, reference, ff, forces, peak)
        except RuntimeError as exc:
            raise PreviewError(f'{motion.name}: the dynamics failed near t={t:.3f} s ({exc})') from None
        if np.any(peak > before):
            peaks.forces(peak, where)
        done += steps
    _sample_wrench(geometry, dyn, support, capacity, forces, peaks, f'{motion.name}, end')
    return n_steps * dt


def _drive_loop(geometry: RobotGeometry, drives: Drives) -> DriveLoop:
    """The compiled loop's drive settings for a robot."""
    speed = geometry.max_speed if drives.max_speed is None else drives.max_speed
    return DriveLoop(kp=float(drives.kp), kd=float(drives.kd), time_constant=float(drives.time_constant),
                     max_speed=np.broadcast_to(np.asarray(speed, dtype=float), (6,)).copy(),
                     min_length=np.broadcast_to(np.asarray(geometry.min_length, dtype=float), (6,)).copy(),
                     max_length=np.broadcast_to(np.asarray(geometry.max_length, dtype=float), (6,)).copy(),
                     max_force=float(geometry.max_force))


def _sample_wrench(geometry, dyn: MultibodyDynamics, support, capacity, forces, peaks: _Peaks,
                   where: str) -> None:
    """The structure's wrench on the supporting ring now, and its holding margin, into the peaks."""
    try:
        r = dyn.reactions(forces)
    except ValueError as exc:
        raise PreviewError(f'{where}: no joint reactions ({exc})') from None
    if support.index == 0:
        wrench = support_wrench(geometry, support, r.universal[None], r.universal_torque[None])[0]
    else:
        wrench = support_wrench(geometry, support, r.spherical[None])[0]
    margin = float(holding_margin(capacity, wrench)) if capacity is not None else math.nan
    peaks.wrench(wrench, margin, support.ring, where)
