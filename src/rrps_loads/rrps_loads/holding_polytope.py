"""A gripper's holding capacity as half-spaces ``G w <= h`` on the wrench it holds, for the timing's
linear program (:mod:`rrps_climbing.timing`).

Each norm bound of :func:`rrps_loads.loads.holding_margin` |x| <= r becomes u_k · x <= r cos θ over
unit directions u_k at most θ apart: conservative by 1 - cos θ (16 plane directions, θ = π/16;
the cube's 26 in space, θ ≈ 27.6°). No ROS import.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from rrps_description.loads import GripperCapacity

__all__ = ['PLANE_DIRECTIONS', 'holding_rows']

PLANE_DIRECTIONS = 16


def _plane() -> tuple[np.ndarray, float]:
    angles = 2.0 * math.pi * np.arange(PLANE_DIRECTIONS) / PLANE_DIRECTIONS
    return np.column_stack([np.cos(angles), np.sin(angles)]), math.cos(math.pi / PLANE_DIRECTIONS)


def _space() -> tuple[np.ndarray, float]:
    u = np.array([d for d in itertools.product((-1.0, 0.0, 1.0), repeat=3) if any(d)])
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    # the farthest point from every direction is equidistant from a face (1,0,0), an edge
    # (1,1,0)/√2 and a corner (1,1,1)/√3 direction: v ∝ (1, √2 - 1, √3 - √2)
    v = np.array([1.0, math.sqrt(2.0) - 1.0, math.sqrt(3.0) - math.sqrt(2.0)])
    return u, float(v[0] / np.linalg.norm(v))


def _to_contact(capacity: GripperCapacity) -> np.ndarray:
    """(6, 6): the wrench about the ring's origin -> (F, M - c × F) about the contact."""
    c = np.asarray(capacity.contact, dtype=float)
    P = np.eye(6)
    P[3:, :3] = -np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
    return P


def holding_rows(capacity: GripperCapacity) -> tuple[np.ndarray, np.ndarray]:
    """(G (r, 6), h (r,)): ``G w <= h`` for the wrench ``w`` (6,) of :func:`holding_margin`
    implies a holding margin >= 0 (module docstring)."""
    P = _to_contact(capacity)
    plane, plane_cos = _plane()
    if capacity.kind == 'friction':
        x = np.array([P[2], P[5] / capacity.radius])                        # (F_z, M_z / r)
        return plane @ x, np.full(len(plane), capacity.friction * capacity.clamp_force * plane_cos)
    space, space_cos = _space()
    rows = [(-P[2:3], np.array([capacity.axial_force])),
            (plane @ P[0:2], np.full(len(plane), capacity.shear_force * plane_cos)),
            (space @ P[3:6], np.full(len(space), capacity.torque * space_cos))]
    return np.concatenate([r[0] for r in rows]), np.concatenate([r[1] for r in rows])
