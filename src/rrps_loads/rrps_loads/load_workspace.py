"""The load-feasible workspace (eq. 19 at rest, :mod:`rrps_loads.loads`): the reachable ring_b
positions (:mod:`rrps_kinematics.workspace`) where, at every orientation, every |f_i| <= max_force
and the supporting gripper's holding margin >= 0::

    ws = load_workspace(geom, q, resolution=0.02, payload=Payload(mass=15.0))
    ws.volume, ws.excluded_by['actuator_force'], ws.excluded_by['holding']

The loads are affine in the payload's mass: a growing payload only shrinks the set.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_kinematics.backend import kernels_of, use_numba
from rrps_kinematics.workspace import UNREACHABLE, Workspace, reachable_workspace
from rrps_loads import compiled_statics
from rrps_loads.support import support_of

__all__ = ['LOAD_LIMITS', 'load_margins', 'load_workspace']

#: The load limits in the order in which they exclude a point.
LOAD_LIMITS = ('actuator_force', 'holding')


def load_margins(geometry: RobotGeometry, points: np.ndarray, quaternion_xyzw, support,
                 *, backend: str = 'auto') -> np.ndarray:
    """(N, 2): max_i |f_i| / max_force and the holding margin (NaN without a capacity) of the
    robot at rest with ring_b at ``points`` (N, 3) and one orientation, on ``support`` (a
    :class:`rrps_loads.support.Support`); NaN forces at a singular pose."""
    q = np.ascontiguousarray(quaternion_xyzw, dtype=float)
    s = compiled_statics.statics_arrays(geometry, support)
    points = np.ascontiguousarray(points, dtype=float)
    if use_numba(backend):
        out = np.empty((len(points), 2))
        compiled_statics.grid_statics(s, points, q, float(geometry.max_force), out)
        return out
    out = [[0.0, 0.0] for _ in range(len(points))]
    kernels_of(compiled_statics, backend).grid_statics(type(s)(*(a.tolist() for a in s)), points.tolist(),
                                                       q.tolist(), float(geometry.max_force), out)
    return np.array(out, dtype=float).reshape(len(points), 2)


def load_workspace(geometry: RobotGeometry, orientations=None, *, resolution: float | None = None,
                   plain: Workspace | None = None, support='ring_a', world_q_support=None, gravity=None,
                   payload=None, tool_wrench=None, backend: str = 'auto', **workspace_options) -> Workspace:
    """The load-feasible workspace as a :class:`Workspace` whose ``excluded_by`` counts the load limits.

    ``plain``: the reachable workspace to restrict (else computed here); the loads' arguments as
    :func:`rrps_loads.loads.static_solution` takes them. ValueError for invalid arguments.
    """
    world = support_of(support, world_q_support, gravity)
    if payload is not None or tool_wrench is not None:
        geometry = geometry.with_(payload=payload or geometry.payload,
                                  tool_wrench=tool_wrench or geometry.tool_wrench)
    if plain is None:
        if resolution is None:
            raise ValueError('give the resolution of the grid, or the plain workspace to restrict')
        plain = reachable_workspace(geometry, orientations, resolution=resolution, backend=backend,
                                    **workspace_options)
    index = np.argwhere(plain.labels != UNREACHABLE)
    points = plain.origin + plain.spacing * index
    excluded = np.full(len(points), -1, dtype=np.int8)
    for q in plain.orientations:
        alive = np.flatnonzero(excluded < 0)
        if not alive.size:
            break
        m = load_margins(geometry, points[alive], q, world, backend=backend)
        over_force = ~(m[:, 0] <= 1.0)
        slipping = ~over_force & (m[:, 1] < 0.0)
        excluded[alive[over_force]] = 0
        excluded[alive[slipping]] = 1
    labels = plain.labels.copy()
    out = index[excluded >= 0]
    labels[out[:, 0], out[:, 1], out[:, 2]] = UNREACHABLE
    counts = np.bincount(excluded[excluded >= 0], minlength=len(LOAD_LIMITS))
    return dataclasses.replace(plain, labels=labels, excluded_by={
        **plain.excluded_by, **{k: int(counts[i]) for i, k in enumerate(LOAD_LIMITS)}})
