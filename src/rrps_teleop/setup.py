from glob import glob

from setuptools import find_packages, setup

package_name = 'rrps_teleop'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools', 'numpy', 'PyYAML', 'mcap', 'mcap-ros2-support', 'foxglove-sdk',
                      'rrps_kinematics', 'rrps_sim'],
    extras_require={'test': ['pytest', 'hypothesis']},
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Teleoperation via a parallel master robot, climbing gaits and the viser viewer.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'master_node = rrps_teleop.nodes.master_node:main',
            'teleop_node = rrps_teleop.nodes.teleop_node:main',
            'climb_node = rrps_teleop.nodes.climb_node:main',
            'viewer_node = rrps_teleop.nodes.viewer_node:main',
            'recorder_node = rrps_teleop.nodes.recorder_node:main',
            'replay_node = rrps_teleop.nodes.replay_node:main',
            'markers_node = rrps_teleop.nodes.markers_node:main',
            'rrps-record = rrps_teleop.record_cli:main',
            'rrps-replay = rrps_teleop.replay_cli:main',
            'rrps-params = rrps_teleop.params:main',
            'rrps-climb = rrps_teleop.climb_cli:main',
            'rrps-demo = rrps_teleop.demo:main',
            'rrps-compose = rrps_teleop.compose:main',
        ],
    },
)
