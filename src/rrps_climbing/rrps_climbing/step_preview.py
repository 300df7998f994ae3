"""A planned step's preview before it executes: its motions on the dynamics, and whether it may start.

:func:`preview_motions` gives :func:`rrps_sim.preview.preview_step` the motions as streamed;
:func:`run_preview` returns a :class:`~rrps_interfaces.climb.ClimbPreview`; :class:`StepSnapshot`
tells whether anything changed meanwhile. No ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from rrps_climbing.plan import Phase
from rrps_climbing.timing import TimedMotion
from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose, pose_error
from rrps_interfaces.climb import ClimbPreview, StepRefusal
from rrps_sim.preview import Drives, PreviewError, PreviewMotion, preview_step

__all__ = ['PreviewConfig', 'preview_motions', 'run_preview', 'warm_up', 'StepSnapshot']


@dataclass(frozen=True)
class PreviewConfig:
    """How steps are previewed: the world's ``gravity`` (3,) [m/s²] in the structure's frame,
    the ``drives`` as the driver models them, the integration step ``dt`` [s], the hold after
    each motion ``settle`` [s] and the smallest holding margin accepted."""

    gravity: tuple = (0.0, 0.0, -9.81)
    drives: Drives = field(default_factory=Drives)
    dt: float = 0.001
    settle: float = 0.2
    min_margin: float = 0.0


def preview_motions(phases: Sequence[Phase], *, period: float) -> list[PreviewMotion]:
    """The motion phases of a plan as the step machine streams them: the sample of the phase's
    timed motion (:class:`~.timing.TimedMotion`) every ``period`` [s]; the support is the ring
    whose gripper stays closed."""
    motions = []
    for ph in phases:
        if not isinstance(ph.timing, TimedMotion):
            continue
        path = ph.timing.phase_path(period)
        support = 'ring_a' if ph.gripper_a else 'ring_b'
        world_T_support = ph.world_T_a if support == 'ring_a' else ph.world_T_b
        motions.append(PreviewMotion(
            name=f'step {ph.step} {ph.phase}', support=support,
            world_q_support=world_T_support.quaternion_xyzw, positions=path.positions,
            quaternions=path.quaternions_xyzw, period=period))
    return motions


def run_preview(geometry: RobotGeometry, phases: Sequence[Phase], *, period: float,
                config: PreviewConfig = PreviewConfig(),
                cancelled: Callable[[], bool] | None = None) -> ClimbPreview:
    """The preview of a plan's phases (accepted when it breaks no limit; not accepted, without a
    ``limit``, when the dynamics could not simulate it)."""
    motions = preview_motions(phases, period=period)
    if not motions:
        return ClimbPreview(accepted=True, max_force=float(geometry.max_force), detail='no motion')
    try:
        r = preview_step(geometry, motions, gravity=config.gravity, drives=config.drives, dt=config.dt,
                         settle=config.settle,
                         min_margin=config.min_margin, cancelled=cancelled)
    except (PreviewError, ValueError) as exc:
        return ClimbPreview(accepted=False, max_force=float(geometry.max_force), detail=f'preview failed: {exc}')
    return ClimbPreview(accepted=r.accepted, peak_force=r.peak_force, peak_leg=r.peak_leg,
                        max_force=r.max_force, peak_reaction_force=r.peak_reaction_force,
                        peak_reaction_moment=r.peak_reaction_moment, min_margin=r.min_margin,
                        min_margin_ring=r.min_margin_ring, limit=r.limit, simulated=r.simulated,
                        wall=r.wall, detail=r.detail)


def warm_up(geometry: RobotGeometry, config: PreviewConfig = PreviewConfig()) -> None:
    """Load the preview's compiled kernels (a still motion at home on each ring), so that the
    first step's preview in a process does not wait seconds for them."""
    positions = np.array([geometry.home_position] * 2, dtype=float)
    quaternions = np.array([geometry.home_quaternion_xyzw] * 2, dtype=float)
    upright = np.array([0.0, 0.0, 0.0, 1.0])
    motions = [PreviewMotion(f'warm-up on {ring}', ring, upright, positions, quaternions, config.dt)
               for ring in ('ring_a', 'ring_b')]
    preview_step(geometry, motions, gravity=config.gravity, drives=config.drives, dt=config.dt, settle=config.dt)


@dataclass(frozen=True)
class StepSnapshot:
    """What a step was planned from: the measured pose and the gripper states when it was
    requested, and how many times teleoperation had engaged and the driver changed state."""

    pose: Pose
    grippers: dict
    engagements: int
    driver_changes: int

    def changed(self, *, pose: Pose | None, grippers: dict | None, engagements: int, driver_changes: int,
                driver_active: bool | None, position_tolerance: float,
                orientation_tolerance: float) -> tuple[StepRefusal, str] | None:
        """Why the step may no longer start as planned (None: nothing changed). Teleoperation
        that engaged, or a driver that changed state, even for a moment, counts. (Inputs that
        went stale meanwhile pause the step once it executes, as at any time.)"""
        if engagements != self.engagements:
            return StepRefusal.TELEOP_ENGAGED, 'teleoperation engaged while the step was previewed'
        if driver_changes != self.driver_changes or driver_active is False:
            return StepRefusal.DRIVER_CHANGED, 'the driver changed state while the step was previewed'
        if grippers != self.grippers:
            return StepRefusal.ROBOT_MOVED, 'the grippers changed while the step was previewed'
        dp, da = pose_error(pose, self.pose)
        if dp > position_tolerance or da > orientation_tolerance:
            return StepRefusal.ROBOT_MOVED, (f'the robot moved {dp * 1e3:.1f} mm / {math.degrees(da):.2f} deg '
                                             'while the step was previewed')
        return None
