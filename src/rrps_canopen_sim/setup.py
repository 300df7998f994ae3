from setuptools import find_packages, setup

package_name = 'rrps_canopen_sim'

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=[
        'canopen',
        'numpy',
        'python-can',
        'rrps_canopen',
        'rrps_description',
        'rrps_runtime',
        'rrps_sim',
    ],
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='A CiA 402 drive simulator for rrps_canopen: simulated drives and I/O on a CAN bus (rrps-drive-sim).',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rrps-drive-sim = rrps_canopen_sim.process:main',
        ],
    },
)
