"""The pure cores import and work on a machine without ROS: every module outside the packages'
``nodes/`` (and the runtime's node modules, and the ROS side of the nodes of teleop, viewer and
recorder) imports with rclpy and every ROS message package made unimportable, and the kinematics
core solves IK and FK there."""

from __future__ import annotations

import subprocess
import sys

_BLOCKED = ('rclpy', 'rcl_interfaces', 'rosidl_runtime_py', 'rpyutils', 'builtin_interfaces', 'std_msgs',
            'std_srvs', 'sensor_msgs', 'geometry_msgs', 'diagnostic_msgs', 'visualization_msgs',
            'lifecycle_msgs', 'tf2_msgs', 'ament_index_python')

_CHECK = f'''
import importlib, importlib.abc, pkgutil, sys

class NoRos(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] in {_BLOCKED!r}:
            raise ImportError(f'no ROS here: {{name}}')
        return None

sys.meta_path.insert(0, NoRos())
ROS_MODULES = {{'rrps_runtime.' + m for m in ('action_host', 'command_path', 'diagnostics', 'messages', 'parameters',
                                               'process', 'qos', 'recording_tap')}} | {{
    'rrps_teleop.support_input', 'rrps_teleop.teleop_stream', 'rrps_teleop.master_feedback',
    'rrps_viewer.operator_requests',
    'rrps_viewer.robot_subscriptions', 'rrps_viewer.recording_clients', 'rrps_recording.topic_graph',
    'rrps_recording.robot_tf', 'rrps_climbing.climb_action', 'rrps_climbing.climb_requests',
    'rrps_viewer.climb_step_client',
    'rrps_viewer.picture'}}
imported = []
for package in ('rrps_description', 'rrps_interfaces', 'rrps_runtime', 'rrps_kinematics', 'rrps_hardware',
                'rrps_loads', 'rrps_sim', 'rrps_teleop', 'rrps_climbing', 'rrps_viewer', 'rrps_recording'):
    root = importlib.import_module(package)
    for info in pkgutil.walk_packages(root.__path__, package + '.'):
        if '.nodes' in info.name or info.name in ROS_MODULES or info.name.endswith(('record_cli', 'replay_cli')):
            continue
        importlib.import_module(info.name)
        imported.append(info.name)
assert not any(m.split('.')[0] in {_BLOCKED!r} for m in sys.modules), 'a ROS module was imported'
import numpy as np
from rrps_description import load_robot
from rrps_kinematics import forward_kinematics, inverse_kinematics
g = load_robot('pole_climber')
p = g.home_position + np.array([0.01, -0.02, 0.03])
lengths = inverse_kinematics(g, p, g.home_quaternion_xyzw).lengths
fk = forward_kinematics(g, lengths)
assert fk.converged and np.allclose(fk.position, p, atol=1e-9), fk
print(len(imported))
'''


def test_the_pure_cores_import_and_solve_without_ros():
    out = subprocess.run([sys.executable, '-c', _CHECK], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert int(out.stdout.split()[-1]) > 80  # the pure modules of eleven packages
