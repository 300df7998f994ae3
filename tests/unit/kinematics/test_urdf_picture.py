"""A picture of the robot driven by its URDF: yourdfpy places the URDF's visuals at the joint
states of a pose, matplotlib draws them headless (no OpenGL here). The picture must show the
robot: its pixels where its meshes project, the legs' green, the tool's orange, the rings' grey.

``RRPS_UPDATE_DOCS_IMAGES=1`` writes it to docs/images/urdf-robot.png (the picture of docs/recording.md);
``RRPS_SCREENSHOT_DIR=dir`` keeps a copy there.
"""

from __future__ import annotations

import io
import os
import shutil
from pathlib import Path

import numpy as np
import yourdfpy
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.image import imsave
from mpl_toolkits.mplot3d import proj3d
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics.inverse import inverse_kinematics
from rrps_kinematics.limits import margins
from rrps_kinematics.urdf_joints import joint_values, robot_urdf

ROOT = Path(__file__).resolve().parents[3]
BACKGROUND = np.array([255, 255, 255])
LIGHT = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])


def render(urdf: yourdfpy.URDF, title: str) -> tuple[np.ndarray, np.ndarray]:
    """(RGB image (H, W, 3) uint8, the pixel box (x0, y0, x1, y1) where the meshes project)."""
    meshes = urdf.scene.dump(concatenate=False)  # every visual, placed by the joint states
    triangles = np.concatenate([m.vertices[m.faces] for m in meshes])
    normals = np.concatenate([m.face_normals for m in meshes])
    colours = np.concatenate([m.visual.face_colors[:, :3] / 255.0 for m in meshes])
    shade = 0.45 + 0.55 * np.clip(normals @ LIGHT, 0.0, 1.0)
    fig = Figure(figsize=(6.4, 5.2), dpi=100, facecolor='white')
    ax = fig.add_axes((0.0, 0.0, 1.0, 0.93), projection='3d')
    ax.add_collection3d(Poly3DCollection(triangles, facecolors=colours * shade[:, None], edgecolors='none'))
    points = triangles.reshape(-1, 3)
    centre, half = 0.5 * (points.min(0) + points.max(0)), 0.5 * np.ptp(points, axis=0).max()
    ax.set(xlim=(centre[0] - half, centre[0] + half), ylim=(centre[1] - half, centre[1] + half),
           zlim=(centre[2] - half, centre[2] + half))
    ax.set_box_aspect((1, 1, 1), zoom=1.35)
    ax.view_init(elev=18, azim=-62)
    ax.set_axis_off()
    fig.suptitle(title, fontsize=10)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    x, y, _ = proj3d.proj_transform(*points.T, ax.get_proj())
    pixels = ax.transData.transform(np.column_stack([x, y]))
    height = image.shape[0]
    box = np.array([pixels[:, 0].min(), height - pixels[:, 1].max(), pixels[:, 0].max(), height - pixels[:, 1].min()])
    return image, box


def test_the_urdf_drawn_at_a_pose_shows_the_robot(tmp_path):
    g = load_robot('pole_climber')
    a_T_b = Pose(g.home_position + [0.04, -0.03, -0.02], rotation_vector_to_quat_xyzw([0.12, 0.08, 0.2]))
    assert margins(g, inverse_kinematics(g, a_T_b.position, a_T_b.quaternion_xyzw)).ok
    urdf = yourdfpy.URDF.load(io.StringIO(robot_urdf(g)), build_collision_scene_graph=False, load_meshes=False)
    urdf.update_cfg(joint_values(g, a_T_b))
    image, box = render(urdf, 'pole_climber from its URDF (rrps-kinematics urdf), ring_b tilted')
    path = tmp_path / 'urdf-robot.png'
    imsave(path, image)
    if os.environ.get('RRPS_UPDATE_DOCS_IMAGES'):
        shutil.copy(path, ROOT / 'docs' / 'images' / 'urdf-robot.png')
    if os.environ.get('RRPS_SCREENSHOT_DIR'):
        shutil.copy(path, Path(os.environ['RRPS_SCREENSHOT_DIR']) / 'urdf-robot.png')

    drawn = np.any(np.abs(image.astype(int) - BACKGROUND) > 30, axis=-1)
    drawn[: int(0.07 * image.shape[0])] = False  # the title
    x0, y0, x1, y1 = np.round(box).astype(int)
    inside = np.zeros_like(drawn)
    inside[max(y0 - 2, 0):y1 + 3, max(x0 - 2, 0):x1 + 3] = True
    assert drawn.sum() > 0.1 * inside.sum()  # the robot covers its projected box
    assert drawn[~inside].sum() < 0.01 * drawn.sum()  # and nothing else is drawn
    rgb = image.astype(float) / 255.0
    r, gr, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    legs = drawn & (gr > r + 0.15) & (gr > b + 0.1)
    tool = drawn & (r > gr + 0.1) & (r > b + 0.2)
    rings = drawn & (np.abs(r - gr) < 0.06) & (b > r + 0.03)
    for part, count in (('legs', legs.sum()), ('tool', tool.sum()), ('rings', rings.sum())):
        assert count > 200, f'no {part} in the picture ({count} pixels)'
    # the tool is on ring_b's side: above the legs' middle in the picture
    assert np.argwhere(tool)[:, 0].mean() < np.argwhere(legs)[:, 0].mean()
