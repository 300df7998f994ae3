from setuptools import find_packages, setup

package_name = 'rrps_sim'
#: The hardware implementations driver_node can host (its ``hardware`` parameter): name ->
#: 'module:SystemInterface subclass', the 'rrps.hardware' entry-point group (rrps_hardware.registry).
HARDWARE = {
    'simulated': 'rrps_sim.simulated_robot:SimulatedRobot',
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
        'rrps_description',
        'rrps_hardware',
        'rrps_interfaces',
        'rrps_kinematics',
        'rrps_loads',
        'rrps_runtime',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Multibody dynamics of RRPS climbing robots and their simulated hardware.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-dynamics = rrps_sim.cli:main',
        ],
        'rrps.hardware': [f'{name} = {target}' for name, target in HARDWARE.items()],
    },
)
