from glob import glob

from setuptools import find_packages, setup

package_name = 'rrps_bringup'
#: The nodes of this package: executable -> (module, node class) (as in rrps_teleop's setup.py).
NODES = {
    'link_relay_node': ('rrps_bringup.nodes.link_relay_node', 'LinkRelayNode'),
}

#: What this package needs at run time without importing it (tests/repo/test_dependencies.py
#: expects each one here, and only those): rrps_hardware and rrps_recording, whose driver_node,
#: recorder_node and markers_node the demo starts (by module name and rrps.nodes entry points).
USED_WITHOUT_IMPORT = ['rrps_hardware', 'rrps_recording']

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/diagnostics', glob('config/diagnostics/*.yaml')),
        ('share/' + package_name + '/config/foxglove', glob('config/foxglove/*.json')),
    ],
    install_requires=[
        'numpy',
        'PyYAML',
        'ros-jazzy-ament-index-python',
        'ros-jazzy-diagnostic-msgs',
        'ros-jazzy-geometry-msgs',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-msgs',
        'ros-jazzy-std-srvs',
        'rrps_canopen',
        'rrps_canopen',
        'rrps_climbing',
        'rrps_description',
        'rrps_hardware',
        'rrps_interfaces',
        'rrps_kinematics',
        'rrps_loads',
        'rrps_runtime',
        'rrps_sim',
        'rrps_teleop',
        'rrps_viewer',
    ] + USED_WITHOUT_IMPORT,
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Bring-up of the rrps stack.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-demo = rrps_bringup.demo:main',
            'rrps-compose = rrps_bringup.compose:main',
            'rrps-params = rrps_bringup.params:main',
        ] + [f'{node} = {module}:main' for node, (module, _) in NODES.items()],
        'rrps.nodes': [f'{node} = {module}:{cls}' for node, (module, cls) in NODES.items()],
    },
)
