"""The typed bundles the compiled kernels take: the robot, a workspace, the observations.

Each is a NamedTuple of arrays, which numba passes as one typed argument: kernels take the robot
as one :class:`DynamicsParameters` (not a dozen positional arrays) and report a state as an
:class:`Observation` with named fields.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import JointGeometry

__all__ = ['WORKSPACE_SIZE', 'DynamicsParameters', 'Observation', 'Observations', 'Workspace',
           'new_workspace', 'workspace']


class DynamicsParameters(NamedTuple):
    """The robot as the kernels see it: its joints (eqs. 3-10) and its 13 bodies' inertia.

    ``mass`` (13,) [kg], ``inertia`` (13, 3, 3) J' about each com in the body frame [kg m^2] and
    its inverse ``inertia_inv``, ``gravity`` (3,) in ring_a's frame [m/s^2], ``com_b`` (3,)
    ring_b's com in its frame [m]. Body 0 is ring_b, 1 + 2k and 2 + 2k leg k's lower and upper
    link.
    """

    joints: JointGeometry
    mass: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    gravity: np.ndarray
    com_b: np.ndarray

    @classmethod
    def of(cls, geometry, joints: JointGeometry) -> DynamicsParameters:
        """The bundle of a RobotGeometry whose multibody model has these joints."""
        mass = np.empty(13)
        inertia = np.empty((13, 3, 3))
        mass[0] = geometry.ring_b_body.mass
        inertia[0] = geometry.ring_b_body.inertia
        for k in range(6):
            mass[1 + 2 * k] = geometry.lower_link.mass
            inertia[1 + 2 * k] = geometry.lower_link.inertia_tensor()
            mass[2 + 2 * k] = geometry.upper_link.mass
            inertia[2 + 2 * k] = geometry.upper_link.inertia_tensor()
        return cls(joints, mass, inertia, np.linalg.inv(inertia),
                   np.ascontiguousarray(geometry.gravity, dtype=float),
                   np.ascontiguousarray(geometry.ring_b_body.com, dtype=float))


class Observation(NamedTuple):
    """What is reported of one state: ring_b's ``position`` (3,) [m] and unit ``euler_parameters``
    (e0, e1, e2, e3) in ring_a's frame, actuator ``lengths`` (6,) [m] and ``length_rates`` (6,)
    [m/s], ``constraint_drift`` ‖Φ^K‖, ``euler_norm_error`` max_b |p_b^T p_b - 1| (eq. 9),
    ``kinetic`` Σ ½ m |ṙ|² + ½ ω'^T J' ω' and ``potential`` -Σ m g·r energies [J]."""

    position: np.ndarray
    euler_parameters: np.ndarray
    lengths: np.ndarray
    length_rates: np.ndarray
    constraint_drift: float
    euler_norm_error: float
    kinetic: float
    potential: float


class Observations(NamedTuple):
    """:class:`Observation` of K states, field by field: arrays with a leading K."""

    position: np.ndarray
    euler_parameters: np.ndarray
    lengths: np.ndarray
    length_rates: np.ndarray
    constraint_drift: np.ndarray
    euler_norm_error: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray

    @classmethod
    def empty(cls, rows: int) -> Observations:
        return cls(np.empty((rows, 3)), np.empty((rows, 4)), np.empty((rows, 6)),
                   np.empty((rows, 6)), np.empty(rows), np.empty(rows), np.empty(rows),
                   np.empty(rows))


class Workspace(NamedTuple):
    """Scratch arrays of the kernels and integrators: views of one flat buffer (:func:`workspace`).

    Evaluation of eq. 19: ``rotations`` A of the 13 bodies, ``forces`` F (78,), each leg's
    ``blocks`` [Φ_r Φ_π'] and ``gamma`` (kept for :func:`multipliers`), ``residual`` Φ of a leg,
    the leg solve's ``reduced`` system [K | 4 right-hand sides], each leg's ``response``
    [H | c], ``effective`` M_l [H | c], ``coupling`` Λ Y and the ring_b system ``ring`` [S | t].
    RK4: stage derivatives ``kq``, ``kv``, ``kw``, stage states ``qs``, ``vs``, the state at the
    start of the step ``q0``, ``v0`` and the partitioned integrator's independent states ``y0``,
    ``ky``."""

    rotations: np.ndarray
    forces: np.ndarray
    blocks: np.ndarray
    gamma: np.ndarray
    residual: np.ndarray
    reduced: np.ndarray
    response: np.ndarray
    effective: np.ndarray
    coupling: np.ndarray
    ring: np.ndarray
    kq: np.ndarray
    kv: np.ndarray
    kw: np.ndarray
    qs: np.ndarray
    vs: np.ndarray
    q0: np.ndarray
    v0: np.ndarray
    y0: np.ndarray
    ky: np.ndarray


#: Floats in a workspace buffer: the sizes of :class:`Workspace`'s fields, in order.
WORKSPACE_SIZE = (117 + 78 + 6 * 13 * 18 + 6 * 13 + 13 + 60 + 6 * 12 * 4 + 48 + 9 + 42
                  + 4 * 91 + 4 * 78 + 4 + 91 + 78 + 91 + 78 + 12 + 48)


def new_workspace() -> np.ndarray:
    """A workspace buffer: allocated once, then every evaluation and step runs in it."""
    return np.zeros(WORKSPACE_SIZE)


@jit
def workspace(buffer):
    """The :class:`Workspace` views of a buffer from :func:`new_workspace` (nothing copied).

    The hot entry points take the flat buffer rather than the NamedTuple, which numba unboxes
    per array at every call from Python."""
    o = 0
    rotations = buffer[o:o + 117].reshape((13, 3, 3))
    o += 117
    forces = buffer[o:o + 78]
    o += 78
    blocks = buffer[o:o + 1404].reshape((6, 13, 18))
    o += 1404
    gamma = buffer[o:o + 78].reshape((6, 13))
    o += 78
    residual = buffer[o:o + 13]
    o += 13
    reduced = buffer[o:o + 60].reshape((6, 10))
    o += 60
    response = buffer[o:o + 288].reshape((6, 12, 4))
    o += 288
    effective = buffer[o:o + 48].reshape((12, 4))
    o += 48
    coupling = buffer[o:o + 9].reshape((3, 3))
    o += 9
    ring = buffer[o:o + 42].reshape((6, 7))
    o += 42
    kq = buffer[o:o + 364].reshape((4, 91))
    o += 364
    kv = buffer[o:o + 312].reshape((4, 78))
    o += 312
    kw = buffer[o:o + 4]
    o += 4
    qs = buffer[o:o + 91]
    o += 91
    vs = buffer[o:o + 78]
    o += 78
    q0 = buffer[o:o + 91]
    o += 91
    v0 = buffer[o:o + 78]
    o += 78
    y0 = buffer[o:o + 12]
    o += 12
    ky = buffer[o:o + 48].reshape((4, 12))
    return Workspace(rotations, forces, blocks, gamma, residual, reduced, response,
                     effective, coupling, ring, kq, kv, kw, qs, vs, q0, v0, y0, ky)
