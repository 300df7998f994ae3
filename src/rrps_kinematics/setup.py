from glob import glob

from setuptools import find_packages, setup

package_name = 'rrps_kinematics'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={package_name: ['robots/*.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/robots', glob('rrps_kinematics/robots/*.yaml')),
    ],
    install_requires=['setuptools', 'numpy', 'scipy', 'PyYAML'],
    extras_require={'test': ['pytest', 'hypothesis']},
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Kinematics and multibody core of RRPS parallel climbing robots, IK and FK nodes.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'ik_node = rrps_kinematics.nodes.ik_node:main',
            'fk_node = rrps_kinematics.nodes.fk_node:main',
            'rrps-kinematics = rrps_kinematics.cli:main',
        ],
    },
)
