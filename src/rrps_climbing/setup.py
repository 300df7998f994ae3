from setuptools import find_packages, setup

package_name = 'rrps_climbing'
#: The nodes of this package: executable -> (module, node class). Registered once, in the
#: 'rrps.nodes' entry-point group that rrps-compose and rrps-params read, and as the
#: console scripts that `ros2 run` starts (lib/<package>/<node>).
NODES = {
    'climb_node': ('rrps_climbing.nodes.climb_node', 'ClimbNode'),
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
        'numpy',
        'scipy',
        'toppra',
        'ruckig',
        'ros-jazzy-diagnostic-msgs',
        'ros-jazzy-geometry-msgs',
        'ros-jazzy-nav-msgs',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-srvs',
        'rrps_description',
        'rrps_interfaces',
        'rrps_kinematics',
        'rrps_loads',
        'rrps_runtime',
        'rrps_sim',
    ],
    extras_require={'test': ['pytest', 'hypothesis']},
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description=('Climbing of RRPS robots: the inchworm gait, frame node crossings, routes, the step machine and '
                 'climb_node.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-climb = rrps_climbing.cli:main',
        ] + [f'{node} = {module}:main' for node, (module, _) in NODES.items()],
        'rrps.nodes': [f'{node} = {module}:{cls}' for node, (module, cls) in NODES.items()],
    },
)
