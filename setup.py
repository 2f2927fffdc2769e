"""ament_python setup for drill_twin (layout after ros2/demos demo_nodes_py)."""
from glob import glob
import os
import subprocess

from setuptools import find_packages, setup

package_name = 'drill_twin'


def _requirements(name):
    # realpath: colcon build --symlink-install runs a symlink to this file from build/
    path = os.path.join(os.path.dirname(os.path.realpath(__file__)), 'requirements', name)
    with open(path) as handle:
        return [line.split('#')[0].strip() for line in handle
                if line.split('#')[0].strip()]


def _revision_file():
    """``resource/git_revision``: the git revision of the tree being installed (``+dirty`` if
    modified), installed to share/drill_twin so that an installed copy (colcon, pip) can
    say in its recordings which sources it ran; empty when this is not a git checkout."""
    here = os.path.dirname(os.path.realpath(__file__))
    path = os.path.join(here, 'resource', 'git_revision')

    def git(*args):
        return subprocess.run(['git', *args], cwd=here, capture_output=True, text=True,
                              timeout=10, check=True).stdout.strip()
    try:
        dirty = git('status', '--porcelain', '--untracked-files=no')
        revision = git('rev-parse', 'HEAD') + ('+dirty' if dirty else '')
    except (OSError, subprocess.SubprocessError):
        revision = ''
    with open(path, 'w') as handle:
        handle.write(revision + '\n')
    return 'resource/git_revision'


setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml', _revision_file()]),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/operations', glob('config/operations/*.yaml')),
        ('share/' + package_name + '/config/wells', glob('config/wells/*.csv')
         + glob('config/wells/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        ('share/' + package_name + '/layouts', glob('layouts/*')),
    ],
    package_data={package_name: ['data/*.yaml', 'data/ros/share/*/msg/*',
                                 'data/ros/share/*/README.md']},
    include_package_data=True,
    install_requires=_requirements('base.txt'),
    extras_require={'ros': _requirements('ros.txt'), 'test': _requirements('dev.txt')},
    zip_safe=True,
    maintainer='drill_twin maintainers',
    maintainer_email='drill-twin@example.com',
    description='ROS 2 digital twin of a deep drilling system (drill-string dynamics).',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'drill-twin = drill_twin.cli:main',
            'twin_node = drill_twin.ros.entry:twin_node',
            'soft_torque_node = drill_twin.ros.entry:soft_torque_node',
            'top_drive_controller = drill_twin.ros.entry:top_drive_controller',
            'mcap_recorder = drill_twin.ros.entry:mcap_recorder',
            'downhole_estimator = drill_twin.ros.entry:downhole_estimator',
            'opcua_bridge = drill_twin.ros.entry:opcua_bridge',
        ],
    },
)
