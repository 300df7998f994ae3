"""rrps_description: RRPS parallel climbing robots as data, and the world they climb.

Pure Python and NumPy, no ROS import: ``load_robot('pole_climber')`` (a shipped name or a robot
YAML path), the one :class:`Pose`, names, rotations, loads, structures; the modules are listed in
docs/architecture.md ('rrps_description (pure)'), the shipped robots are ``robots/*.yaml``.
"""

from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot, robot_path, shipped_robots
from rrps_description.pose import InvalidPose, Pose, validate_pose

__all__ = ['InvalidPose', 'Pose', 'RobotDescriptionError', 'RobotGeometry', 'load_robot', 'robot_path',
           'shipped_robots', 'validate_pose']
