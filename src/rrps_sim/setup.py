from setuptools import find_packages, setup

package_name = 'rrps_sim'
#: The nodes of this package: executable -> (module, node class). Registered once, in the
#: 'rrps.nodes' entry-point group that rrps-compose and rrps-params read, and as the
#: console scripts that `ros2 run` starts (lib/<package>/<node>).
NODES = {
    'driver_node': ('rrps_sim.nodes.driver_node', 'DriverNode'),
}
#: The hardware implementations driver_node can host (its ``hardware`` parameter): name ->
#: 'module:SystemInterface subclass', the 'rrps.hardware' entry-point group (rrps_sim.hardware).
HARDWARE = {
    'simulated': 'rrps_sim.hardware.simulated:SimulatedRobot',
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
        'numpy',
        'scipy',
        'ros-jazzy-rcl-interfaces',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-srvs',
        'rrps_description',
        'rrps_interfaces',
        'rrps_runtime',
        'rrps_kinematics',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Multibody dynamics of RRPS climbing robots and the hardware driver node.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-dynamics = rrps_sim.cli:main',
        ] + [f'{node} = {module}:main' for node, (module, _) in NODES.items()],
        'rrps.nodes': [f'{node} = {module}:{cls}' for node, (module, cls) in NODES.items()],
        'rrps.hardware': [f'{name} = {target}' for name, target in HARDWARE.items()],
    },
)
