from glob import glob

from setuptools import find_packages, setup

package_name = 'rrps_canopen'
#: The hardware implementations of this package: driver_node's ``hardware`` (the 'rrps.hardware'
#: entry points) and master_node's (the 'rrps.master_hardware' entry points), by name.
HARDWARE = {'canopen': 'rrps_canopen.robot:CanopenRobot'}
MASTER_HARDWARE = {'canopen': 'rrps_canopen.master_hardware:CanopenMaster'}

#: What this package needs at run time without importing it (tests/repo/test_dependencies.py
#: expects each one here, and only those): msgpack, with which python-can's udp_multicast packs
#: the loopback bus' frames (python-can's own multicast extra would pin an older msgpack).
USED_WITHOUT_IMPORT = ['msgpack']

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test']),
    package_data={package_name: ['eds/*.eds']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/eds', glob(package_name + '/eds/*.eds')),
    ],
    install_requires=[
        'canopen',
        'numpy',
        'python-can',
        'rrps_description',
        'rrps_hardware',
        'rrps_kinematics',
        'rrps_runtime',
    ] + USED_WITHOUT_IMPORT,
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='CANopen (CiA 402, CiA 401) hardware of RRPS robots and a loopback CAN bus.',
    license='Apache-2.0',
    entry_points={
        'rrps.hardware': [f'{name} = {target}' for name, target in HARDWARE.items()],
        'rrps.master_hardware': [f'{name} = {target}' for name, target in MASTER_HARDWARE.items()],
        'can.interface': ['rrps_loopback = rrps_canopen.loopback_bus:LoopbackBus'],
    },
)
