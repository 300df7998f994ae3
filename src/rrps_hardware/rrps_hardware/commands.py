"""What the driver checks of a command before it reaches the hardware: the stroke of the legs and
the range of the rings' extra DOF (paper section 3.1, Figure 9). Pure Python, no ROS import."""

from __future__ import annotations

from typing import Mapping

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.names import LEG_NAMES, RINGS, ring_joint
from rrps_hardware.interface import Command
from rrps_runtime.freshness import RejectedCommand

__all__ = ['ring_joints', 'checked_command']


def ring_joints(geometry: RobotGeometry) -> list[str]:
    """The joint names of the robot's ring DOFs, in ring order (none for most robots)."""
    return [ring_joint(ring) for ring in RINGS if ring in geometry.extra_dof]


def checked_command(geometry: RobotGeometry, lengths, ring_angles: Mapping[str, float], ring_targets, *,
                    stamp: float | None = None) -> Command:
    """The command of the leg ``lengths`` (6,) [m] and of the ring angles [rad] named in
    ``ring_angles`` (the other rings keep ``ring_targets``), stamped ``stamp`` [s];
    RejectedCommand outside the stroke or a ring's range."""
    g = geometry
    lengths = np.asarray(lengths, dtype=float)
    outside = (lengths < g.min_length) | (lengths > g.max_length)
    if np.any(outside):
        legs = [LEG_NAMES[i] for i in np.flatnonzero(outside)]
        raise RejectedCommand(f'lengths of {legs} outside the stroke [{g.min_length}, {g.max_length}] m')
    present = [ring for ring in RINGS if ring in g.extra_dof]
    if not any(ring_joint(ring) in ring_angles for ring in present):
        return Command(lengths, stamp=stamp)
    rings = np.array([ring_angles.get(ring_joint(ring), target) for ring, target in zip(present, ring_targets)],
                     dtype=float)
    lo = np.array([g.extra_dof[ring].min_angle for ring in present])
    hi = np.array([g.extra_dof[ring].max_angle for ring in present])
    if not np.all(np.isfinite(rings)) or np.any(rings < lo) or np.any(rings > hi):
        raise RejectedCommand(f'ring rotations {rings} outside their limits')
    return Command(lengths, rings, stamp)
