from setuptools import find_packages, setup

package_name = 'rrps_runtime'

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
        'PyYAML',
        'rosbags',
        'ros-jazzy-diagnostic-msgs',
        'ros-jazzy-geometry-msgs',
        'ros-jazzy-nav-msgs',
        'ros-jazzy-rcl-interfaces',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-sensor-msgs',
        'ros-jazzy-std-msgs',
        'rrps_description',
        'rrps_interfaces',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='What every rrps node runs on.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
        ],
    },
)
