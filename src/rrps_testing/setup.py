from setuptools import find_packages, setup

package_name = 'rrps_testing'

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
        'pytest',
        'PyYAML',
        'ros-jazzy-diagnostic-msgs',
        'ros-jazzy-geometry-msgs',
        'ros-jazzy-lifecycle-msgs',
        'ros-jazzy-rcl-interfaces',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-msgs',
        'ros-jazzy-std-srvs',
        'rrps_bringup',
        'rrps_canopen',
        'rrps_climbing',
        'rrps_description',
        'rrps_hardware',
        'rrps_interfaces',
        'rrps_kinematics',
        'rrps_runtime',
        'rrps_teleop',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Test and benchmark support of the rrps stack.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
        ],
    },
)
