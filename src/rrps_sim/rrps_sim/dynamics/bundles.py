"""The typed bundles the compiled kernels take: the robot, a workspace, the observations.

Each is a NamedTuple of arrays, which numba passes as one typed argument: kernels take the robot
as one :class:`DynamicsParameters` (not a dozen positional arrays) and report a state as an
:class:`Observation` with named fields.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rrps_description.world import Support
from rrps_kinematics.backend import jit
from rrps_kinematics.multibody import JointGeometry, MultibodyModel
from rrps_loads.support import tool_wrench_in_support

__all__ = ['WORKSPACE_SIZE', 'DynamicsParameters', 'Observation', 'Observations', 'Reactions',
           'Workspace', 'hub_joints', 'new_workspace', 'workspace']


class DynamicsParameters(NamedTuple):
    """The robot as the kernels see it: its joints (eqs. 3-10) and its 13 bodies' inertia, SI units.

    ``support`` 0 grounds ring_a, 1 ring_b; body 0 is the hub, 1 + 2k and 2 + 2k leg k's lower and upper
    link. Inertias are about each com in the body frame, ``gravity`` in the ground's frame; ``tool_wrench``
    (4, 3) is fixed in the ground (rows 0, 1) or turns with the hub (rows 2, 3), zeros with ring_b grounded."""

    joints: JointGeometry
    support: int
    mass: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    gravity: np.ndarray
    hub_com: np.ndarray
    tool_point: np.ndarray
    tool_wrench: np.ndarray

    @classmethod
    def of(cls, geometry, support: Support) -> DynamicsParameters:
        """The bundle of a RobotGeometry on a support (:class:`~rrps_description.world.Support`)."""
        hub = geometry.ring_b_body if support.index == 0 else geometry.ring_a_body
        mass = np.empty(13)
        inertia = np.empty((13, 3, 3))
        mass[0] = hub.mass
        inertia[0] = hub.inertia
        for k in range(6):
            mass[1 + 2 * k] = geometry.lower_link.mass
            inertia[1 + 2 * k] = geometry.lower_link.inertia_tensor()
            mass[2 + 2 * k] = geometry.upper_link.mass
            inertia[2 + 2 * k] = geometry.upper_link.inertia_tensor()
        wrench = np.zeros((4, 3))
        tool_point = np.zeros(3)
        if support.index == 0 and geometry.tool_wrench is not None:
            tool_point = geometry.tool.position - hub.com
            w = geometry.tool_wrench
            if w.frame == 'world':
                wrench[0], wrench[1] = support.world_R_support.T @ w.force, support.world_R_support.T @ w.torque
            else:
                force, torque = tool_wrench_in_support(geometry, support, np.eye(3)[None])
                wrench[2], wrench[3] = force[0], torque[0]
        return cls(hub_joints(geometry, support), support.index, mass, inertia, np.linalg.inv(inertia),
                   np.array(support.gravity_in_support), np.ascontiguousarray(hub.com, dtype=float),
                   tool_point, wrench)


def hub_joints(geometry, support: Support) -> JointGeometry:
    """The joint data of eqs. 3-10 as :mod:`.constraints` reads it for a support: ``a`` the
    ground's joint centres (its frame), ``sb`` the hub's (from its com, in its frame), ``ha`` the
    universal joints' fixed axes in ring_a's frame."""
    joints = MultibodyModel(geometry).joints
    if support.index == 0:
        return joints
    return JointGeometry(a=np.ascontiguousarray(geometry.ring_b_anchors, dtype=float), ha=joints.ha,
                         sb=np.ascontiguousarray(geometry.ring_a_anchors - geometry.ring_a_body.com),
                         cl=joints.cl, cu=joints.cu)


class Reactions(NamedTuple):
    """The joint reactions of K states, from the multipliers of eq. 19, in the ground's frame
    [N, N m]: the force ring_a exerts on each leg at its universal joint, ``universal``
    (K, 6, 3), and the torque, ``universal_torque`` (K, 6, 3); the force ring_b exerts at the
    spherical joint, ``spherical`` (K, 6, 3)."""

    universal: np.ndarray
    universal_torque: np.ndarray
    spherical: np.ndarray

    @classmethod
    def empty(cls, rows: int) -> Reactions:
        return cls(np.empty((rows, 6, 3)), np.empty((rows, 6, 3)), np.empty((rows, 6, 3)))


class Observation(NamedTuple):
    """What is reported of one state: the hub's ``position`` (3,) [m] and unit
    ``euler_parameters`` (e0, e1, e2, e3) in the ground's frame (a_T_b with ring_a grounded),
    actuator ``lengths`` (6,) [m] and ``length_rates`` (6,)
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
    """Scratch arrays of the kernels and integrators (eq. 19's blocks, the RK4 stages): views of one
    flat buffer (:func:`workspace`), so that an evaluation allocates nothing."""

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
WORKSPACE_SIZE = (117 + 78 + 6 * 13 * 18 + 6 * 13 + 13 + 66 + 6 * 12 * 5 + 60 + 12 + 42
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
    reduced = buffer[o:o + 66].reshape((6, 11))
    o += 66
    response = buffer[o:o + 360].reshape((6, 12, 5))
    o += 360
    effective = buffer[o:o + 60].reshape((12, 5))
    o += 60
    coupling = buffer[o:o + 12].reshape((4, 3))
    o += 12
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
