"""The rrps web viewer for remote operators (viser), as a small public facade.

Pure scene and control logic (no rclpy, no viser) is importable and testable on its own; poses
are :class:`rrps_description.pose.Pose` (re-exported here)::

    from rrps_viewer import Pose, robot_figure, world_ring_poses, OperatorControl
    world_T_a, world_T_b = world_ring_poses(a_T_b=pose, gripping='ring_a', world_T_gripping=odom)
    fig = robot_figure(geom, a_T_b=pose, world_T_a=world_T_a, efforts=efforts)
    fig.leg_points      # (6, 2, 3) world: universal-joint centre -> spherical-joint centre
    fig.leg_colours     # (6, 3) uint8 from the stroke, joint-angle and force margins
    control = OperatorControl(token='...')   # token, single controller, hand-over, deadman

The viser layer (``ViewerServer``, ``Frame``) is imported on first use so that the pure parts
do not need viser.
"""

from rrps_description.pose import Pose
from rrps_kinematics.scene import (
    WARN_FRACTION,
    RobotFigure,
    Trail,
    leg_margin_fractions,
    margin_colours,
    robot_figure,
    torus_mesh,
    world_ring_poses,
)
from rrps_viewer._control import ControlResult, OperatorControl
from rrps_viewer._workspace import WorkspaceSnapshot, WorkspaceView, boundary_points

__all__ = [
    'ControlResult',
    'Frame',
    'OperatorActions',
    'OperatorControl',
    'Pose',
    'RobotFigure',
    'Trail',
    'ViewerServer',
    'RecordingControls',
    'send_file',
    'WARN_FRACTION',
    'WorkspaceSnapshot',
    'WorkspaceView',
    'boundary_points',
    'leg_margin_fractions',
    'margin_colours',
    'robot_figure',
    'torus_mesh',
    'world_ring_poses',
]


def __getattr__(name: str):
    if name in ('Frame', 'ViewerServer'):
        from . import _render
        return getattr(_render, name)
    if name == 'OperatorActions':
        from . import _operator_panel
        return _operator_panel.OperatorActions
    if name in ('RecordingControls', 'send_file'):
        from . import _recording
        return getattr(_recording, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
