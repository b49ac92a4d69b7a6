"""ament_python package: console scripts land in lib/hand_tracker_ros so `ros2 run` finds them."""
import runpy
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'hand_tracker_ros'

# The node list has one home; setup.py runs before the package is importable.
NODES = runpy.run_path(str(Path(__file__).resolve().parent / PACKAGE / 'graph_nodes.py'))['NODES']

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'bench']),
    package_data={PACKAGE: ['vision/models/*.onnx']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml') + glob('config/*.xml')
         + glob('config/*.rviz') + glob('config/*.json')),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
        (f'share/{PACKAGE}/urdf', glob('urdf/*.urdf')),
        (f'share/{PACKAGE}/requirements', ['requirements/train.txt']),
        (f'share/{PACKAGE}/msg_defs/hand_tracker_msgs/msg',
         glob('msg_defs/hand_tracker_msgs/msg/*.msg')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='hand_tracker_ros developers',
    maintainer_email='hand-tracker@example.com',
    description='Markerless multi-camera hand motion capture for ROS 2.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            *(f'{name} = {PACKAGE}.entry:{name}' for name in NODES),
            f'hand-tracker = {PACKAGE}.entry:cli',
        ],
    },
)
