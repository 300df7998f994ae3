"""The viewer's first view (rrps_viewer._camera) has the robot, the structure around it and
the master in the picture, in every demo scenario and for the demo's default robot: checked by
projecting those points through a pinhole camera written here (up +z, viser's vertical field of
view, a view 0.8 as wide as high: the 3-D view left of the docked panel in a window of 860 x 600 px
is 0.87) from the camera the viewer sets. The fixed camera the
viewer had before cuts the frame climber off at the node (the check fails there)."""

from __future__ import annotations

import contextlib
import math
from types import SimpleNamespace

import numpy as np
import pytest

from rrps_bringup.scenarios import SCENARIOS, scenario
from rrps_climbing.frame_crossing import FrameNodePlanner
from rrps_climbing.gait import GaitPlanner
from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_description.structures import make_structure
from rrps_kinematics.scene import robot_figure
from rrps_viewer._camera import FirstView, framing, scene_points

MASTER_ORIGIN = Pose([0.0, -0.9, 0.0])  # viewer_node's default console
FOV = math.radians(75.0)
ASPECT = 0.8   # width / height of the narrowest 3-D view framed for


def _in_view(points, position, look_at, fov=FOV, aspect=ASPECT) -> np.ndarray:
    """Which points a pinhole camera at ``position`` looking at ``look_at`` (up +z) sees."""
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(points) - position
    depth = d @ forward
    t = math.tan(fov / 2)
    return (depth > 0) & (np.abs(d @ right) <= aspect * t * depth) & (np.abs(d @ up) <= t * depth)


def _start(name: str | None):
    """(robot figure at the start, structure vertices, reach) of a scenario or the plain demo."""
    s = scenario(name) if name else None
    robot = load_robot(s.robot if s else 'pole_climber')
    structure = s.structure_model() if s else make_structure('pole')
    if s and s.junction_deg > 0.0:
        planner = FrameNodePlanner(robot, s.junction_deg)
        start = planner.crossing.candidate.s_pre
        world_T_a, world_T_b = planner.world_rings(start, start, 0.0, 0.0)
    else:
        planner = GaitPlanner(robot, structure)
        world_T_a, world_T_b = planner.world_rings(0.5, 0.5 + planner.sep_home, 0.0, 0.0)
    figure = robot_figure(robot, a_T_b=world_T_a.inverse() @ world_T_b, world_T_a=world_T_a)
    return figure, structure.mesh()[0], 1.5 * robot.characteristic_length


@pytest.mark.parametrize('name', [None, *sorted(SCENARIOS)])
def test_the_first_view_has_the_robot_its_structure_and_the_master(name):
    figure, vertices, reach = _start(name)
    master_geometry = load_robot('master_robot')
    master = robot_figure(master_geometry, a_T_b=Pose(master_geometry.home_position,
                                                     master_geometry.home_quaternion_xyzw),
                          world_T_a=MASTER_ORIGIN)
    points = scene_points(figure, master, vertices, reach)
    position, look_at = framing(points)
    # it looks at the centre of the points' bounding sphere, whose outline is inside the view
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    radius = np.linalg.norm(points - centre, axis=1).max()
    np.testing.assert_allclose(look_at, centre, atol=1e-12)
    half_width = math.atan(ASPECT * math.tan(FOV / 2))
    assert math.asin(radius / np.linalg.norm(centre - position)) < min(FOV / 2, half_width)
    robot = figure.leg_points.reshape(-1, 3)
    assert np.all(_in_view(robot, position, look_at))
    assert np.all(_in_view(master.leg_points.reshape(-1, 3), position, look_at))
    near = vertices[np.linalg.norm(vertices - robot.mean(axis=0), axis=1) <= reach]
    # the member around the robot (a facade is one wall: its corners are far, the robot on it)
    assert (len(near) > 0 or name == 'facade_wall') and np.all(_in_view(near, position, look_at))
    # the robot is not a speck: it spans a fair part of the picture's height
    distance = np.linalg.norm(robot.mean(axis=0) - position)
    span = np.ptp(robot, axis=0).max()
    assert span / (2.0 * distance * math.tan(FOV / 2)) > 0.05


def test_the_old_fixed_camera_cut_the_frame_climber_off():
    figure, _, _ = _start('frame_node')
    old = _in_view(figure.leg_points.reshape(-1, 3), np.array([1.2, -2.0, 1.2]), np.array([0.3, -0.35, 0.4]))
    assert not np.all(old)


class _Camera:
    position = look_at = None


class _Client:
    """A viser client as FirstView uses it: its camera and ``atomic()``."""

    def __init__(self):
        self.camera = _Camera()

    def atomic(self):
        return contextlib.nullcontext()


def test_every_browser_gets_the_framing_also_one_that_connects_while_it_is_made():
    figure, vertices, reach = _start(None)
    server = SimpleNamespace(initial_camera=_Camera())
    view = FirstView(server, vertices, reach)
    early, racing, late = _Client(), _Client(), _Client()
    view.show(early)                       # connected before any framing: nothing to show yet
    assert early.camera.position is None
    frame = SimpleNamespace(slave=figure, master=None, trails={'ring_a': [figure.world_T_a.position]})
    view.update(frame, lambda: [early])    # `racing` connected, but its handler has not run yet
    expected = framing(scene_points(figure, None, vertices, reach))
    view.show(racing)                      # its handler runs now
    view.show(late)
    for camera in (server.initial_camera, early.camera, racing.camera, late.camera):
        np.testing.assert_allclose(camera.position, expected[0])
        np.testing.assert_allclose(camera.look_at, expected[1])
    moved = (1.0, 2.0, 3.0)
    early.camera.position = moved
    view.update(frame, lambda: [early])    # framed once: a browser the user moved stays put
    assert early.camera.position == moved
