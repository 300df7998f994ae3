"""rrps_description: RRPS parallel climbing robots as data, and the world they climb.

Pure Python and NumPy, no ROS import::

    from rrps_description import load_robot, shipped_robots, Pose
    geom = load_robot('pole_climber')     # a shipped robot, or the path of a robot YAML
    geom.anchors_a, geom.anchors_b        # (6, 3) joint centres in ring_a / ring_b [m]

Modules: ``geometry`` (the robot YAML and its validation), ``robot_parts`` (tools, inertias,
the extra ring DOF), ``names`` (frames, joints, rings), ``pose`` (the one pose type and its
validator), ``rotations``, ``tool`` (the tool-centre point), ``loads`` (payloads, the tool
wrench, gripper capacities), ``world`` (gravity, the supporting ring's attitude), ``structures``
(poles, palm trunks, frames, facades). The shipped robots are ``robots/*.yaml`` (installed to share/rrps_description).
"""

from rrps_description.geometry import RobotDescriptionError, RobotGeometry, load_robot, robot_path, shipped_robots
from rrps_description.pose import InvalidPose, Pose, validate_pose

__all__ = ['InvalidPose', 'Pose', 'RobotDescriptionError', 'RobotGeometry', 'load_robot', 'robot_path',
           'shipped_robots', 'validate_pose']
