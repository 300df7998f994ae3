from glob import glob

from setuptools import find_packages, setup

package_name = 'rrps_description'

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test']),
    package_data={package_name: ['robots/*.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/robots', glob(package_name + '/robots/*.yaml')),
    ],
    install_requires=[
        'numpy',
        'PyYAML',
        'scipy',
    ],
    zip_safe=True,
    maintainer='rrps maintainers',
    maintainer_email='maintainers@users.noreply.h-seed-0d31557d.example',
    description='Description of RRPS parallel climbing robots.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
        ],
    },
)
