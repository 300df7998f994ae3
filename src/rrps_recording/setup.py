from setuptools import find_packages, setup

package_name = 'rrps_recording'
#: The nodes of this package: executable -> (module, node class). Registered once, in the
#: 'rrps.nodes' entry-point group that rrps-compose and rrps-params read, and as the
#: console scripts that `ros2 run` starts (lib/<package>/<node>).
NODES = {
    'recorder_node': ('rrps_recording.nodes.recorder_node', 'RecorderNode'),
    'replay_node': ('rrps_recording.nodes.replay_node', 'ReplayNode'),
    'markers_node': ('rrps_recording.nodes.markers_node', 'MarkersNode'),
    'foxglove_node': ('rrps_recording.nodes.foxglove_node', 'FoxgloveNode'),
}

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=[
        'foxglove-sdk',
        'mcap',
        'numpy',
        'PyYAML',
        'rosbags',
        'ros-jazzy-builtin-interfaces',
        'ros-jazzy-diagnostic-msgs',
        'ros-jazzy-geometry-msgs',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-rosgraph-msgs',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-msgs',
        'ros-jazzy-std-srvs',
        'ros-jazzy-visualization-msgs',
        'rrps_description',
        'rrps_interfaces',
        'rrps_kinematics',
        'rrps_runtime',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Recording and replay of the rrps topics, and the robot for RViz2 and Foxglove.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-record = rrps_recording.record_cli:main',
            'rrps-replay = rrps_recording.replay_cli:main',
        ] + [f'{node} = {module}:main' for node, (module, _) in NODES.items()],
        'rrps.nodes': [f'{node} = {module}:{cls}' for node, (module, cls) in NODES.items()],
    },
)
