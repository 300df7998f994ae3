"""The viewer's 3-D scene nodes, all in the ``world`` frame (REP-103, z up): built once by :func:`build_scene`, then
moved by the drawing thread of :mod:`rrps_viewer._render` (scene names in its docstring) through :func:`draw_robot`.
"""

from __future__ import annotations

import numpy as np

from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_kinematics.scene import RobotFigure, torus_mesh

__all__ = ['build_scene', 'add_robot', 'add_tool', 'draw_robot', 'ring_mesh']


def ring_mesh(geometry: RobotGeometry, anchors: np.ndarray):
    """A ring's torus through its leg anchors."""
    radius = float(np.mean(np.linalg.norm(anchors[:, :2], axis=1)))
    return torus_mesh(radius=radius, tube=max(0.08 * radius, 1e-3))


def build_scene(scene, n: dict, geometry: RobotGeometry, master_geometry: RobotGeometry | None,
                structure, master_origin: Pose) -> None:
    """Every scene node of the viewer into ``n`` (by name): structure, grid, robot, ghost, trails, master."""
    if structure is not None:
        vertices, faces = structure
        n['/structure'] = scene.add_mesh_simple(
            '/structure', np.asarray(vertices, dtype=np.float32),
            np.asarray(faces, dtype=np.uint32), color=(150, 110, 70), side='double')
    n['/grid'] = scene.add_grid('/grid', width=4.0, height=4.0, cell_size=0.25,
                                plane='xy', position=(0.0, 0.0, 0.0))
    add_robot(scene, n, '/robot', geometry, (120, 130, 150), opacity=None)
    n['/ghost/ring_b'] = scene.add_mesh_simple(
        '/ghost/ring_b', *ring_mesh(geometry, geometry.ring_b_anchors),
        color=(90, 170, 255), opacity=0.35, visible=False)
    for ring, colour in (('ring_a', (230, 120, 20)), ('ring_b', (20, 140, 230))):
        n[f'/trail/{ring}'] = scene.add_line_segments(
            f'/trail/{ring}', points=np.zeros((1, 2, 3)), colors=colour, thickness=0.006,
            visible=False)
    if master_geometry is not None:
        add_robot(scene, n, '/master', master_geometry, (160, 160, 160), opacity=None)
        n['/master/feedback'] = scene.add_line_segments(
            '/master/feedback', points=np.zeros((1, 2, 3)), colors=(220, 40, 40),
            thickness=4.0, visible=False)
        n['/master/label'] = scene.add_label('/master/label', 'master robot',
                                             position=master_origin.position + [0, 0, 0.2])
    n['/robot/label'] = scene.add_label('/robot/ring_b/label', 'ring_b', position=(0, 0, 0.05))


def add_robot(scene, n: dict, prefix: str, geometry: RobotGeometry, colour, *, opacity) -> None:
    """A robot's ring frames and bodies, grippers (the slave's), tool and legs under ``prefix``."""
    for ring, anchors in (('ring_a', geometry.ring_a_anchors),
                          ('ring_b', geometry.ring_b_anchors)):
        radius = float(np.mean(np.linalg.norm(anchors[:, :2], axis=1)))
        n[f'{prefix}/{ring}'] = scene.add_frame(f'{prefix}/{ring}', axes_length=0.4 * radius,
                                                axes_radius=0.02 * radius)
        n[f'{prefix}/{ring}/body'] = scene.add_mesh_simple(
            f'{prefix}/{ring}/body', *ring_mesh(geometry, anchors), color=colour,
            opacity=opacity)
        if prefix == '/robot':
            n[f'{prefix}/grippers/{ring}'] = scene.add_mesh_simple(
                f'{prefix}/{ring}/gripper', *torus_mesh(radius=0.45 * radius,
                                                        tube=0.06 * radius),
                color=(200, 200, 200))
    if geometry.tool is not None:
        add_tool(scene, n, prefix, geometry.tool, colour=(200, 90, 40) if prefix == '/robot'
                       else (150, 150, 150))
    thickness = 2.0 * max(geometry.leg_radius, 0.004 * geometry.characteristic_length)
    n[f'{prefix}/legs'] = scene.add_line_segments(
        f'{prefix}/legs', points=np.zeros((6, 2, 3)), colors=(40, 170, 70), thickness=thickness)


def add_tool(scene, n: dict, prefix: str, tool, *, colour) -> None:
    """The tool on ring_b (its frame ``b_T_tool``, the shape ending at the tool-centre point)."""
    x, y, z, w = tool.quaternion_xyzw
    frame = f'{prefix}/ring_b/tool'
    n[frame] = scene.add_frame(frame, position=tool.position, wxyz=(w, x, y, z),
                                        axes_length=0.05, axes_radius=0.002)
    if tool.shape == 'cylinder':
        radius, length = tool.size
        n[f'{frame}/shape'] = scene.add_cylinder(
            f'{frame}/shape', radius=radius, height=length, color=colour,
            position=(0.0, 0.0, -0.5 * length))
    elif tool.shape == 'box':
        n[f'{frame}/shape'] = scene.add_box(
            f'{frame}/shape', dimensions=tool.size, color=colour,
            position=(0.0, 0.0, -0.5 * tool.size[2]))
    else:
        n[f'{frame}/shape'] = scene.add_icosphere(
            f'{frame}/shape', radius=tool.size[0], color=colour)


def draw_robot(n: dict, prefix: str, figure: RobotFigure) -> None:
    """Move a robot's rings and legs to ``figure`` (arrays sent only when they changed)."""
    for ring, pose in (('ring_a', figure.world_T_a), ('ring_b', figure.world_T_b)):
        n[f'{prefix}/{ring}'].position = pose.position
        n[f'{prefix}/{ring}'].wxyz = pose.wxyz
    legs = n[f'{prefix}/legs']
    points = figure.leg_points.astype(np.float32)
    if not np.array_equal(points, legs.points):  # arrays are not de-duplicated by viser
        legs.points = points
    colours = np.repeat(figure.leg_colours[:, None, :], 2, axis=1)
    if not np.array_equal(colours, legs.colors):
        legs.colors = colours
