"""Virtual fixture: the slave's limits felt on the master as a feedback wrench (§3.1).

:func:`fixture_wrench` gives the wrench [N, N m] in ring_a's frame that pushes the slave's ring_b
back inside its workspace: per limit kind of :func:`rrps_kinematics.limits.margins` whose smallest
margin m is below its activation distance d, ``F = min(stiffness (d - m) / d, max_force)`` along
the gradient of the kind's soft minimum ``-tau log sum_i exp(-m_i / tau)`` (tau = 0.1 d) with
respect to ring_b's twist (:mod:`rrps_kinematics.jacobian`'s convention), torque over the robot's
length L. The kinds add up, scaled to ``max_force`` and ``max_torque``; :func:`master_wrench`
maps it to the master. Pure NumPy, no ROS import; see docs/architecture.md, 'rrps_teleop'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import validate_pose
from rrps_description.rotations import quat_multiply_xyzw, rotation_vector_to_quat_xyzw
from rrps_kinematics import inverse_kinematics, margins
from rrps_kinematics.workspace import LIMIT_KINDS
from rrps_teleop.mapping import validate_scale
from rrps_teleop.teleop_config import PARAMETERS

__all__ = ['DEFAULT_ACTIVATION', 'FixtureConfig', 'FixtureWrench', 'fixture_wrench', 'master_wrench']

#: Activation distances per limit kind, in the margins' units. Conditioning: 0.06 above the
#: shipped robots' min_conditioning (0.02) is the teleop guard's slow-down threshold (0.08);
#: interference: the guard's collision_slowdown.
DEFAULT_ACTIVATION = MappingProxyType({'stroke': 0.02, 'universal': 0.1, 'spherical': 0.1,
                                       'interference': 0.02, 'conditioning': 0.06})
#: Central finite-difference step of the margins' gradient [m and rad].
GRADIENT_STEP = 1e-6
#: Soft-min temperature, as a fraction of the activation distance (see the module docstring).
SOFTMIN_FRACTION = 0.1


@dataclass(frozen=True)
class FixtureConfig:
    """Fixture parameters (SI units); validated on construction (ValueError). ``activation`` per limit
    kind (0: off; keep it well below the margins' peaks), ``stiffness`` [N] the push at a limit."""

    activation: Mapping[str, float] = field(default_factory=lambda: dict(DEFAULT_ACTIVATION))
    stiffness: float = PARAMETERS['fixture_stiffness'].default
    max_force: float = 20.0
    max_torque: float = 2.0

    def __post_init__(self) -> None:
        unknown = set(self.activation) - set(LIMIT_KINDS)
        if unknown:
            raise ValueError(f'activation: unknown limit kinds {sorted(unknown)}, expected {LIMIT_KINDS}')
        activation = {**DEFAULT_ACTIVATION, **self.activation}
        for kind, d in activation.items():
            if isinstance(d, bool) or not isinstance(d, (int, float)) or not (math.isfinite(d) and d >= 0.0):
                raise ValueError(f'activation[{kind!r}] must be a finite number >= 0, got {d!r}')
        object.__setattr__(self, 'activation',
                           MappingProxyType({k: float(activation[k]) for k in LIMIT_KINDS}))
        for name in ('stiffness', 'max_force', 'max_torque'):
            object.__setattr__(self, name, validate_scale(getattr(self, name), name))


@dataclass(frozen=True)
class FixtureWrench:
    """The fixture's wrench on the slave's ring_b, in ring_a's frame (see the module docstring).

    ``force`` (3,) [N]; ``torque`` (3,) [N m] about ring_b's origin; ``dominant``: the kind with
    the largest push, None when nothing pushes; ``pushes``: each kind's magnitude F [N] before
    the total's saturation; ``margins``: the smallest margin of each kind at the pose.
    """

    force: np.ndarray
    torque: np.ndarray
    dominant: str | None
    pushes: dict
    margins: dict


def _perturbed_poses(position: np.ndarray, quaternion: np.ndarray, step: float):
    """The pose, then the 12 poses moved by the twists +step e_j and -step e_j (j = 0..5: dp along
    x, y, z, then dtheta about x, y, z, in ring_a's frame): (13, 3), (13, 4)."""
    twists = np.concatenate([np.zeros((1, 6)), step * np.eye(6), -step * np.eye(6)])
    P = position + twists[:, :3]
    Q = quat_multiply_xyzw(rotation_vector_to_quat_xyzw(twists[:, 3:]), quaternion)
    return P, Q


def fixture_wrench(geometry: RobotGeometry, position, quaternion_xyzw,
                   config: FixtureConfig | None = None) -> FixtureWrench:
    """The feedback wrench of the slave ``geometry`` at its pose a_T_b (ring_b in ring_a).

    ``position`` [m] (3,) and unit ``quaternion_xyzw`` (4,); ValueError for NaN/inf, a
    non-unit quaternion, or a degenerate pose whose margins are not finite.
    """
    config = config or FixtureConfig()
    p, q = validate_pose(position, quaternion_xyzw, what='slave pose')
    P, Q = _perturbed_poses(p, q, GRADIENT_STEP)
    m = margins(geometry, inverse_kinematics(geometry, P, Q))
    components = {'stroke': m.stroke, 'universal': m.universal, 'spherical': m.spherical,
                  'interference': m.interference, 'conditioning': m.conditioning[:, None]}
    L = geometry.characteristic_length
    scale = np.array([1.0, 1.0, 1.0, 1.0 / L, 1.0 / L, 1.0 / L])
    force, torque = np.zeros(3), np.zeros(3)
    pushes, smallest = {}, {}
    for kind in LIMIT_KINDS:
        values = components[kind]                      # (13, n): the pose, +step, -step
        here = values[0]
        if not np.all(np.isfinite(here)):
            raise ValueError(f'slave pose: the {kind} margins are not finite (degenerate pose)')
        smallest[kind] = float(np.min(here))
        d = config.activation[kind]
        push = 0.0 if d == 0.0 or smallest[kind] >= d else min(
            config.stiffness * (d - smallest[kind]) / d, config.max_force)
        pushes[kind] = push
        if push == 0.0:
            continue
        weights = np.exp(-(here - smallest[kind]) / (SOFTMIN_FRACTION * d))
        slopes = (values[1:7] - values[7:13]) / (2.0 * GRADIENT_STEP)      # (6, n)
        gradient = scale * (slopes @ (weights / weights.sum()))
        norm = float(np.linalg.norm(gradient))
        if not (math.isfinite(norm) and norm > 0.0):
            continue  # no direction (an extremum of the margin): this kind cannot push
        n = gradient / norm
        force += push * n[:3]
        torque += push * L * n[3:]
    f, t = float(np.linalg.norm(force)), float(np.linalg.norm(torque))
    saturation = min(1.0, config.max_force / f if f > 0.0 else math.inf,
                     config.max_torque / t if t > 0.0 else math.inf)
    dominant = max(LIMIT_KINDS, key=lambda k: pushes[k]) if any(pushes.values()) else None
    return FixtureWrench(force=force * saturation, torque=torque * saturation, dominant=dominant,
                         pushes=pushes, margins=smallest)


def master_wrench(wrench: FixtureWrench, *, translation_scale: float,
                  force_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """The fixture wrench on the master's ring_b: (force [N], torque [N m]) in master_ring_a's frame,
    about the master ring_b's origin. The force is scaled by ``force_scale`` c, the torque by c / s
    (s = ``translation_scale``), keeping the line of action. ValueError unless s, c are finite > 0."""
    s = validate_scale(translation_scale, 'translation_scale')
    c = validate_scale(force_scale, 'force_scale')
    return c * wrench.force, (c / s) * wrench.torque
