from glob import glob

from setuptools import find_packages, setup

package_name = 'rrps_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools', 'numpy', 'scipy', 'rrps_kinematics'],
    extras_require={'test': ['pytest', 'hypothesis']},
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Simulated hardware driver and multibody dynamics of RRPS climbing robots.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'driver_node = rrps_sim.nodes.driver_node:main',
            'rrps-dynamics = rrps_sim.cli:main',
        ],
    },
)
