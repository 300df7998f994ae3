"""The rrps web viewer for remote operators (viser), as a small public facade (docs/viewer.md).

The pure scene and control logic (no rclpy, no viser: :func:`robot_figure`, :func:`world_ring_poses`,
:class:`OperatorControl`) imports on its own; poses are :class:`rrps_description.pose.Pose`. The viser layer
(``ViewerServer``, ``Frame``) is imported on first use.
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
