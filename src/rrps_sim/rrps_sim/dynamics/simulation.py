"""Batch runs of the DAE (eqs. 19-20) on either ring: start at rest at a pose, integrate, record
every step, and the joint reactions and the support's wrench if asked."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.world import Support
from rrps_kinematics.inverse import pose_arrays
from rrps_loads.loads import support_wrench
from rrps_sim.dynamics.bundles import Observations, Reactions
from rrps_sim.dynamics.frames import supported_pose
from rrps_sim.dynamics.model import MultibodyDynamics, RunRecord

__all__ = ['SimulationResult', 'simulate']


@dataclass(frozen=True)
class SimulationResult:
    """One row per output step. Energies [J], times [s], a_T_b; ``step_flops`` and ``step_seconds``:
    the mean per step since the previous row. With reactions, the joint reactions (K, 6, 3) [N] and
    ``support_wrench`` (K, 6) [N, N m] in the supporting ring's frame; else None."""

    t: np.ndarray
    position: np.ndarray
    quaternion_xyzw: np.ndarray
    lengths: np.ndarray
    length_rates: np.ndarray
    forces: np.ndarray
    constraint_drift: np.ndarray
    euler_norm_error: np.ndarray
    energy_balance: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    actuator_work: np.ndarray
    step_flops: np.ndarray
    step_seconds: np.ndarray
    method: str
    dt: float
    corrections: int
    support: Support
    universal_reactions: np.ndarray | None = None
    spherical_reactions: np.ndarray | None = None
    support_wrench: np.ndarray | None = None


def simulate(geometry: RobotGeometry, position, quaternion_xyzw,
             forces: np.ndarray | Callable[[float, MultibodyDynamics], np.ndarray],
             duration: float = 0.5, dt: float = 0.001, method: str = 'hybrid',
             output_every: int = 1, progress: Callable[[float], None] | None = None,
             reactions: bool = False, **options) -> SimulationResult:
    """Start at rest at a pose a_T_b and integrate for ``duration`` s with steps of ``dt`` s.

    ``forces``: constant (6,) [N] (one compiled loop) or ``f(t, dyn) -> (6,)`` held over each step;
    ``options`` go to :class:`MultibodyDynamics`."""
    pose_arrays(position, quaternion_xyzw)
    for name, value in (('duration', duration), ('dt', dt)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f'{name} must be a positive number of seconds, got {value!r}')
    if dt > duration:
        raise ValueError(f'dt ({dt}) must not exceed duration ({duration})')
    if not (isinstance(output_every, (int, np.integer)) and output_every >= 1):
        raise ValueError(f'output_every must be an integer >= 1, got {output_every!r}')
    dyn = MultibodyDynamics(geometry, method, **options)
    dyn.reset(position, quaternion_xyzw)
    n_steps = int(round(duration / dt))
    if callable(forces):
        record, applied = _stepwise(dyn, forces, dt, n_steps, output_every, progress, reactions)
    else:
        constant = _checked_forces(forces)
        record = dyn.run(constant, dt, n_steps, output_every=output_every, progress=progress,
                         reactions=reactions)
        applied = np.tile(constant, (len(record.t), 1))
    # each row after the first stands for the steps since the previous row: their means
    starts = np.arange(0, n_steps, output_every)
    counts = np.diff(np.append(starts, n_steps))
    obs = record.observed
    work = record.actuator_work
    position, quaternion = supported_pose(obs.position, obs.euler_parameters, dyn.support)
    joint = {}
    if record.reactions is not None:
        r = record.reactions
        at_support = r.universal if dyn.support.index == 0 else r.spherical
        torques = r.universal_torque if dyn.support.index == 0 else None
        joint = dict(universal_reactions=r.universal, spherical_reactions=r.spherical,
                     support_wrench=support_wrench(geometry, dyn.support, at_support, torques))
    return SimulationResult(
        t=record.t, position=position, quaternion_xyzw=quaternion, lengths=obs.lengths,
        length_rates=obs.length_rates, forces=applied,
        constraint_drift=obs.constraint_drift, euler_norm_error=obs.euler_norm_error,
        energy_balance=obs.kinetic + obs.potential - work - dyn.initial_energy,
        kinetic=obs.kinetic, potential=obs.potential, actuator_work=work,
        step_flops=np.concatenate([[0], np.add.reduceat(record.step_flops, starts) // counts]),
        step_seconds=np.concatenate([[0.0], np.add.reduceat(record.step_seconds, starts) / counts]),
        method=method, dt=float(dt), corrections=dyn.corrections, support=dyn.support, **joint)


def _stepwise(dyn: MultibodyDynamics, force_fn, dt: float, n_steps: int, output_every: int,
              progress, reactions: bool) -> tuple[RunRecord, np.ndarray]:
    """The run with forces from ``force_fn(t, dyn)`` at each step: Python between the steps."""
    rows = 1 + -(-n_steps // output_every)
    observed = Observations.empty(rows)
    recorded = Reactions.empty(rows) if reactions else None
    t, work, applied = np.empty(rows), np.empty(rows), np.empty((rows, 6))
    flops, seconds = np.empty(n_steps, dtype=np.int64), np.empty(n_steps)
    report_every = max(1, n_steps // 100)

    def record(row, f):
        for field, value in zip(observed, dyn.observation):
            field[row] = value
        t[row], work[row], applied[row] = dyn.time, dyn.actuator_work, f
        if reactions:
            for field, value in zip(recorded, dyn.reactions(f)):
                field[row] = value

    record(0, _checked_forces(force_fn(0.0, dyn)))
    for i in range(n_steps):
        f = _checked_forces(force_fn(dyn.time, dyn))
        start = time.perf_counter()
        dyn.step(f, dt)
        seconds[i] = time.perf_counter() - start
        flops[i] = dyn.last_step_flops
        if (i + 1) % output_every == 0 or i + 1 == n_steps:
            record((i + output_every) // output_every, f)
        if progress is not None and ((i + 1) % report_every == 0 or i + 1 == n_steps):
            progress((i + 1) / n_steps)
    return RunRecord(t, observed, work, flops, seconds, recorded), applied


def _checked_forces(f) -> np.ndarray:
    f = np.asarray(f, dtype=float)
    if f.shape != (6,) or not np.all(np.isfinite(f)):
        raise ValueError(f'forces must be 6 finite numbers [N], got shape {f.shape}')
    return f
