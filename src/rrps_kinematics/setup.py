from setuptools import find_packages, setup

package_name = 'rrps_kinematics'
#: The nodes of this package: executable -> (module, node class). Registered once, in the
#: 'rrps.nodes' entry-point group that rrps-compose and rrps-params read, and as the
#: console scripts that `ros2 run` starts (lib/<package>/<node>).
NODES = {
    'ik_node': ('rrps_kinematics.nodes.ik_node', 'IkNode'),
    'fk_node': ('rrps_kinematics.nodes.fk_node', 'FkNode'),
    'robot_description_node': ('rrps_kinematics.nodes.robot_description_node', 'RobotDescriptionNode'),
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
        'matplotlib',
        'numba',
        'numpy',
        'scipy',
        'ros-jazzy-geometry-msgs',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-msgs',
        'rrps_description',
        'rrps_interfaces',
        'rrps_runtime',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Kinematics of RRPS parallel climbing robots.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-kinematics = rrps_kinematics.cli:main',
        ] + [f'{node} = {module}:main' for node, (module, _) in NODES.items()],
        'rrps.nodes': [f'{node} = {module}:{cls}' for node, (module, cls) in NODES.items()],
    },
)
