"""Launch the hand tracker graph in a full ROS 2 install (`ros2 launch hand_tracker_ros ...`).

The same five nodes as `hand-tracker launch`, each with its config/<node>.yaml. ``launch`` and
``launch_ros`` are not on PyPI, so this file is only used with a full ROS 2 installation; all
logic lives in the nodes.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

NODES = ('features', 'salient_points', 'tracker', 'player', 'recorder')


def generate_launch_description():
    share = get_package_share_directory('hand_tracker_ros')
    use_sim_time = LaunchConfiguration('use_sim_time')
    return LaunchDescription([
        *[DeclareLaunchArgument(f'{name}_params',
                                default_value=os.path.join(share, 'config', f'{name}.yaml'),
                                description=f'ros__parameters YAML of the {name} node')
          for name in NODES],
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='follow /clock (bag replay)'),
        SetEnvironmentVariable('FASTDDS_DEFAULT_PROFILES_FILE',
                               os.path.join(share, 'config', 'fastdds_large_data.xml')),
        *[Node(package='hand_tracker_ros', executable=name, name=name, output='screen',
               parameters=[LaunchConfiguration(f'{name}_params'),
                           {'use_sim_time': use_sim_time}])
          for name in NODES],
    ])
