"""Batch runs of the DAE (eqs. 19-20): start at rest at a pose, integrate, record every step."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rrps_kinematics.geometry import RobotGeometry
from rrps_kinematics.inverse import pose_arrays
from rrps_kinematics.rotations import euler_parameters_to_quat_xyzw, normalize_quat

from .model import MultibodyDynamics

__all__ = ['SimulationResult', 'simulate']


@dataclass(frozen=True)
class SimulationResult:
    """One row per output step (K rows). Energies [J], times [s], flops per step (model)."""

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


def simulate(geometry: RobotGeometry, position, quaternion_xyzw,
             forces: np.ndarray | Callable[[float, MultibodyDynamics], np.ndarray],
             duration: float = 0.5, dt: float = 0.001, method: str = 'hybrid',
             output_every: int = 1, progress: Callable[[float], None] | None = None,
             **options) -> SimulationResult:
    """Start at rest at a pose and integrate for ``duration`` s with steps of ``dt`` s.

    ``forces``: constant (6,) [N] or ``f(t, dyn) -> (6,)`` evaluated at the start of each step
    (held over it). Rows are written at t = 0 and every ``output_every`` steps (and at the end).
    ``progress(fraction)`` is called about 100 times. ``options`` go to MultibodyDynamics.
    """
    pose_arrays(position, quaternion_xyzw)
    for name, value in (('duration', duration), ('dt', dt)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f'{name} must be a positive number of seconds, got {value!r}')
    if dt > duration:
        raise ValueError(f'dt ({dt}) must not exceed duration ({duration})')
    if not (isinstance(output_every, (int, np.integer)) and output_every >= 1):
        raise ValueError(f'output_every must be an integer >= 1, got {output_every!r}')
    if callable(forces):
        force_fn = forces
    else:
        constant = np.asarray(forces, dtype=float)
        if constant.shape != (6,) or not np.all(np.isfinite(constant)):
            raise ValueError(f'forces must be 6 finite numbers [N], got shape {constant.shape}')
        force_fn = lambda t, dyn: constant  # noqa: E731
    dyn = MultibodyDynamics(geometry, method, **options)
    dyn.reset(position, quaternion_xyzw)
    n_steps = int(round(duration / dt))
    rows: dict[str, list] = {key: [] for key in (
        't', 'obs', 'forces', 'actuator_work', 'step_flops', 'step_seconds')}

    def record(f, flops, seconds):
        rows['t'].append(dyn.time)
        rows['obs'].append(dyn.observation)
        rows['forces'].append(f)
        rows['actuator_work'].append(dyn.actuator_work)
        rows['step_flops'].append(flops)
        rows['step_seconds'].append(seconds)

    f = _checked_forces(force_fn(0.0, dyn))
    record(f, 0, 0.0)
    report_every = max(1, n_steps // 100)
    flops_acc, seconds_acc = 0, 0.0
    for i in range(1, n_steps + 1):
        f = _checked_forces(force_fn(dyn.time, dyn))
        t0 = time.perf_counter()
        dyn.step(f, dt)
        seconds_acc += time.perf_counter() - t0
        flops_acc += dyn.last_step_flops
        if i % output_every == 0 or i == n_steps:
            k = (i - 1) % output_every + 1
            record(f, flops_acc // k, seconds_acc / k)
            flops_acc, seconds_acc = 0, 0.0
        if progress is not None and (i % report_every == 0 or i == n_steps):
            progress(i / n_steps)
    obs = rows.pop('obs')
    arrays = {key: np.asarray(val) for key, val in rows.items()}
    fields = {name: np.asarray([getattr(o, name) for o in obs]) for name in obs[0]._fields}
    return SimulationResult(
        **arrays, position=fields['position'],
        quaternion_xyzw=normalize_quat(euler_parameters_to_quat_xyzw(fields['euler_parameters'])),
        lengths=fields['lengths'], length_rates=fields['length_rates'],
        constraint_drift=fields['constraint_drift'], euler_norm_error=fields['euler_norm_error'],
        kinetic=fields['kinetic'], potential=fields['potential'],
        energy_balance=(fields['kinetic'] + fields['potential'] - arrays['actuator_work']
                        - dyn.initial_energy),
        method=method, dt=float(dt), corrections=dyn.corrections)


def _checked_forces(f) -> np.ndarray:
    f = np.asarray(f, dtype=float)
    if f.shape != (6,) or not np.all(np.isfinite(f)):
        raise ValueError(f'forces must be 6 finite numbers [N], got shape {f.shape}')
    return f
