"""The robot as URDF, generated from its description: the tree robot_state_publisher, RViz2 and
Foxglove read (docs/recording.md, 'robot_description and RViz2'). Pure Python, no ROS import.

The five loops close at ring_b, which hangs on ``leg_1_tip``; the joint values of
:mod:`rrps_kinematics.urdf_joints` put every tip link on its ring_b anchor. :func:`socket_frames`
puts each spherical joint's z on its neutral axis, so its middle angle never exceeds the cone."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rrps_description.geometry import RobotGeometry, per_geometry
from rrps_description.names import BASE_FRAME, LEG_NAMES, RING_A_FRAME, RING_B_FRAME, ring_joint
from rrps_description.pose import Pose
from rrps_description.rotations import cross, matrix_to_rpy
from rrps_description.tool import TARGET_FRAMES
from rrps_description.urdf_elements import Inertial, Joint, Link, RobotModel, Shape

__all__ = ['Shape', 'Inertial', 'Link', 'Joint', 'RobotModel', 'LegChain', 'leg_chain',
           'socket_frames', 'urdf_model', 'UNBOUNDED']

#: What a limit the robot description leaves unbounded is written as (URDF needs numbers).
UNBOUNDED = 1e9
#: The tool's link: the tool-centre-point frame, named as ik_node's target frame.
TOOL_LINK = TARGET_FRAMES[1]
_AXES = {'x': (1.0, 0.0, 0.0), 'y': (0.0, 1.0, 0.0), 'z': (0.0, 0.0, 1.0)}


@dataclass(frozen=True)
class LegChain:
    """Joint and link names of leg ``leg`` (1..6): universal (x, y), the prismatic actuator
    (the leg's name), spherical (z, x, y), and the links between them."""

    universal: tuple[str, str]
    prismatic: str
    spherical: tuple[str, str, str]
    links: tuple[str, str, str, str, str, str]  # cross, lower, upper, spherical z, x, tip

    @property
    def joints(self) -> tuple[str, ...]:
        return (*self.universal, self.prismatic, *self.spherical)

    @property
    def tip(self) -> str:
        return self.links[-1]


def leg_chain(leg: int) -> LegChain:
    """The names of leg ``leg``'s chain (1..6)."""
    if leg not in range(1, 7):
        raise ValueError(f'leg must be 1..6, got {leg!r}')
    p = f'leg_{leg}'
    return LegChain(universal=(f'{p}_universal_x', f'{p}_universal_y'), prismatic=LEG_NAMES[leg - 1],
                    spherical=(f'{p}_spherical_z', f'{p}_spherical_x', f'{p}_spherical_y'),
                    links=(f'{p}_universal_cross', f'{p}_lower', f'{p}_upper', f'{p}_spherical_z_link',
                           f'{p}_spherical_x_link', f'{p}_tip'))


def _frames(z: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Frames (N, 3, 3) with columns x, y, z: z given, x normal to z and ``reference``."""
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    x = cross(z, reference)
    for fallback in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)):
        bad = np.linalg.norm(x, axis=-1) < 1e-9
        x[bad] = cross(z[bad], np.array(fallback))
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    return np.stack([x, cross(z, x), z], axis=-1)


@per_geometry
def socket_frames(geometry: RobotGeometry) -> np.ndarray:
    """Each spherical joint's socket frame in ring_b (b_R_tip), shape (6, 3, 3), read-only: z along
    the joint's neutral axis pointing away from ring_a (the leg's direction there), x normal to it
    and to the anchor b_i. The frame of the leg's tip links."""
    frames = _frames(-np.asarray(geometry.ring_b_joint_axes), np.asarray(geometry.ring_b_anchors))
    frames.setflags(write=False)
    return frames


def _bounded(value: float) -> float:
    return float(value) if math.isfinite(value) else UNBOUNDED


def _origin(position, rotation=None) -> dict:
    rpy = (0.0, 0.0, 0.0) if rotation is None else matrix_to_rpy(rotation)
    return {'xyz': tuple(float(v) for v in position), 'rpy': tuple(float(v) for v in rpy)}


class _Sizes:
    """The primitives' dimensions [m]: rings as cylinders around the viewer's torus (mean anchor
    radius r, tube 0.08 r), grippers as collars of radius 0.45 r at the ring's origin, the legs'
    lower and upper bodies as cylinders of the leg radius, each ``body`` long (the shortest leg,
    or half the longest if that is more: the two always overlap), joint centres as spheres."""

    def __init__(self, g: RobotGeometry):
        self.ring = {ring: float(np.mean(np.linalg.norm(anchors[:, :2], axis=1)))
                     for ring, anchors in ((RING_A_FRAME, g.ring_a_anchors), (RING_B_FRAME, g.ring_b_anchors))}
        self.leg = g.leg_radius if g.leg_radius > 0.0 else 0.01 * g.characteristic_length
        reach = g.max_length if math.isfinite(g.max_length) else float(np.max(g.home_lengths))
        self.body = max(g.min_length, 0.5 * reach)

    def ring_shape(self, ring: str) -> Shape:
        tube = max(0.08 * self.ring[ring], 1e-3)
        return Shape('cylinder', (self.ring[ring] + tube, 2.0 * tube), material='ring')

    def gripper_shape(self, ring: str) -> Shape:
        r = max(self.ring[ring], 1e-2)
        return Shape('cylinder', (0.45 * r, 0.4 * r), material='gripper')


def _inertial(body) -> Inertial:
    return Inertial(float(body.mass), np.asarray(body.com, dtype=float), np.asarray(body.inertia, dtype=float))


def _leg(g: RobotGeometry, sizes: _Sizes, i: int, yoke: np.ndarray) -> tuple[list[Link], list[Joint]]:
    """Leg i+1's links and joints, from ring_a to its tip."""
    names = leg_chain(i + 1)
    cross_link, lower, upper, sz, sx, tip = names.links
    u_max, s_max = g.universal_max_angle, g.spherical_max_angle
    body, r = sizes.body, sizes.leg
    ball = Shape('sphere', (1.2 * r,), material='joint')
    lower_body = Shape('cylinder', (r, body), (0.0, 0.0, 0.5 * body), material='leg')
    upper_body = Shape('cylinder', (r, body), (0.0, 0.0, -0.5 * body), material='leg')

    def leg_link(name: str, part, sign: float, shape: Shape) -> Link:
        return Link(name, (shape,), (shape,),
                    Inertial(part.mass, np.array([0.0, 0.0, sign * part.com_from_joint]), part.inertia_tensor()))

    links = [Link(cross_link, (ball,)), leg_link(lower, g.lower_link, 1.0, lower_body),
             leg_link(upper, g.upper_link, -1.0, upper_body), Link(sz), Link(sx), Link(tip, (ball,))]
    tilt = {'lower': -u_max, 'upper': u_max}
    cone = {'lower': -s_max, 'upper': s_max}
    joints = [
        Joint(names.universal[0], 'revolute', RING_A_FRAME, cross_link, axis=_AXES['x'], **tilt,
              **_origin(g.ring_a_anchors[i], yoke)),
        Joint(names.universal[1], 'revolute', cross_link, lower, axis=_AXES['y'], **tilt),
        Joint(names.prismatic, 'prismatic', lower, upper, axis=_AXES['z'], lower=float(g.min_length),
              upper=_bounded(g.max_length), effort=_bounded(g.max_force), velocity=_bounded(g.max_speed)),
        Joint(names.spherical[0], 'continuous', upper, sz, axis=_AXES['z']),
        Joint(names.spherical[1], 'revolute', sz, sx, axis=_AXES['x'], **cone),
        Joint(names.spherical[2], 'revolute', sx, tip, axis=_AXES['y'], **cone),
    ]
    return links, joints


def _ring_parts(g: RobotGeometry, sizes: _Sizes, ring: str) -> tuple[list[Link], list[Joint]]:
    """A ring's gripper: fixed to it, or on the extra DOF's revolute joint (section 3.1)."""
    kind = g.grippers.get(ring, 'none')
    dof = g.extra_dof.get(ring)
    if kind == 'none' and dof is None:
        return [], []
    shapes = (sizes.gripper_shape(ring),) if kind != 'none' else ()
    link = Link(f'{ring}_gripper', shapes, shapes)
    if dof is None:
        return [link], [Joint(f'{ring}_gripper_mount', 'fixed', ring, link.name)]
    return [link], [Joint(ring_joint(ring), 'revolute', ring, link.name, axis=tuple(float(v) for v in dof.axis),
                          lower=float(dof.min_angle), upper=float(dof.max_angle))]


def _tool(g: RobotGeometry) -> tuple[list[Link], list[Joint]]:
    t = g.tool
    if t is None:
        return [], []
    if t.shape == 'cylinder':
        shape = Shape('cylinder', t.size, (0.0, 0.0, -0.5 * t.size[1]), material='tool')
    elif t.shape == 'box':
        shape = Shape('box', t.size, (0.0, 0.0, -0.5 * t.size[2]), material='tool')
    else:
        shape = Shape('sphere', t.size, material='tool')
    link = Link(TOOL_LINK, (shape,), (shape,), Inertial(t.mass, np.asarray(t.com), np.asarray(t.inertia)))
    pose = Pose(t.position, t.quaternion_xyzw)
    return [link], [Joint(f'{TOOL_LINK}_mount', 'fixed', RING_B_FRAME, TOOL_LINK,
                          **_origin(pose.position, pose.rotation))]


def _notes(g: RobotGeometry, sizes: _Sizes) -> tuple[str, ...]:
    unbounded = [key for key, value in (('max_length', g.max_length), ('max_force', g.max_force),
                                        ('max_speed', g.max_speed)) if not math.isfinite(value)]
    return tuple(note for note in (
        f'Robot {g.name!r}, generated from its robot description by rrps (rrps-kinematics urdf). '
        'SI units; base_link (REP-105) is the root, ring_a fixed on it; all kinematics is for a_T_b '
        '(ring_b in ring_a).',
        'URDF describes a tree and cannot close loops: the six legs close five loops through ring_b. '
        'ring_b hangs on leg_1 (fixed joint ring_b_on_leg_1 on leg_1_tip); legs 2-6 end in tip links at '
        'their spherical-joint centres. Joint values from the IK of a_T_b (rrps_kinematics.urdf_joints, '
        'robot_description_node) put every tip on its ring_b anchor.',
        'Universal joint: leg_i_universal_x (about the yoke axis fixed in ring_a) then leg_i_universal_y, '
        'at the ring_a anchor. Prismatic leg_i: the joint value is the leg length. Spherical joint: three '
        'revolute joints in the order z (twist about the leg), x, y, at the ring_b anchor; the tip link '
        'is the socket frame fixed in ring_b, z along the neutral axis, so the home pose has x = y = 0 '
        'and |x| never exceeds the cone angle: gimbal lock (x = +-pi/2) lies outside the cone unless '
        'spherical_max_angle >= pi/2.',
        'Joint limits: the stroke on leg_i; the universal and spherical cones (angle from the neutral '
        'axis <= max angle, cos(angle) = cos(x) cos(y)) are not URDF limits: each pair of tilt joints '
        'is limited to the box [-max, max]^2, which contains the cone. The twist is not limited '
        '(continuous). Passive joints and the extra ring DOF have effort and velocity 0 (none given).',
        f'Unbounded in the robot description, written as {UNBOUNDED:g}: {", ".join(unbounded)}.'
        if unbounded else '',
        'Inertias from the robot description: the rings (ring_a\'s on ring_a_body), the legs\' lower '
        'and upper links (com along the leg, transverse and axial '
        'inertias), the tool. Visuals and collisions are primitives: rings as cylinders around the '
        f'torus, grippers as collars, the legs\' lower and upper bodies as cylinders of radius {sizes.leg:g} m '
        f'and length {sizes.body:g} m, joint centres as spheres.',
    ) if note)


def urdf_model(geometry: RobotGeometry, universal_frames: np.ndarray) -> RobotModel:
    """The URDF of ``geometry``. ``universal_frames`` (6, 3, 3): each universal joint's yoke
    frame in ring_a (:func:`rrps_kinematics.inverse.universal_joint_frames`), which defines the
    joint angles of the IK (x = the axis fixed in ring_a)."""
    g = geometry
    frames = np.asarray(universal_frames, dtype=float)
    if frames.shape != (6, 3, 3):
        raise ValueError(f'universal_frames must have shape (6, 3, 3), got {frames.shape}')
    sizes = _Sizes(g)
    ring_a, ring_b = sizes.ring_shape(RING_A_FRAME), sizes.ring_shape(RING_B_FRAME)
    body = f'{RING_A_FRAME}_body'
    links = [Link(BASE_FRAME), Link(RING_A_FRAME, (ring_a,), (ring_a,)),
             Link(body, inertial=_inertial(g.ring_a_inertia))]
    joints = [Joint(f'{RING_A_FRAME}_on_base', 'fixed', BASE_FRAME, RING_A_FRAME),
              Joint(f'{body}_mount', 'fixed', RING_A_FRAME, body)]
    parts = [_ring_parts(g, sizes, RING_A_FRAME)]
    parts += [_leg(g, sizes, i, frames[i]) for i in range(6)]
    tip_R_b = socket_frames(g)[0].T
    parts.append(([Link(RING_B_FRAME, (ring_b,), (ring_b,), _inertial(g.ring_b_inertia))],
                  [Joint(f'{RING_B_FRAME}_on_leg_1', 'fixed', leg_chain(1).tip, RING_B_FRAME,
                         **_origin(-(tip_R_b @ g.ring_b_anchors[0]), tip_R_b))]))
    parts += [_ring_parts(g, sizes, RING_B_FRAME), _tool(g)]
    for part_links, part_joints in parts:
        links += part_links
        joints += part_joints
    return RobotModel(g.name, tuple(links), tuple(joints), _notes(g, sizes))
