"""Launch the hand tracker graph in a full ROS 2 install (`ros2 launch hand_tracker_ros ...`).

The same graph and arguments as `hand-tracker launch`, each node with its config/<node>.yaml:
``rig:=RIG`` (required: the tracker refuses to start without it), ``bag:=BAG``, ``rate:=R``,
``loop:=true``, ``use_sim_time:=true`` for a bag, and ``mode``: ``composed`` (default), one
``tracker`` process that also hosts ``features`` and ``salient_points`` (data passed in
memory), or ``distributed``, the three as processes over DDS. ``launch`` and ``launch_ros``
are not on PyPI, so this file is only used with a full ROS 2 installation; all logic lives in
the nodes.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node

from hand_tracker_ros.graph_nodes import NODES
from launch import LaunchDescription


def generate_launch_description():
    share = get_package_share_directory('hand_tracker_ros')
    use_sim_time = LaunchConfiguration('use_sim_time')
    mode = LaunchConfiguration('mode')
    distributed = PythonExpression(["'", mode, "' == 'distributed'"])
    inputs = PythonExpression(["'features' if '", mode, "' == 'distributed' else 'images'"])

    def node(name, **extra):
        # No `name=`: a node name remap would rename every node of the composed process.
        return Node(package='hand_tracker_ros', executable=name, output='screen',
                    parameters=[LaunchConfiguration(f'{name}_params'),
                                {'use_sim_time': use_sim_time}, *extra.pop('more', ())],
                    **extra)

    return LaunchDescription([
        *[DeclareLaunchArgument(f'{name}_params',
                                default_value=os.path.join(share, 'config', f'{name}.yaml'),
                                description=f'ros__parameters YAML of the {name} node')
          for name in NODES],
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='follow /clock (bag replay)'),
        DeclareLaunchArgument('rig', default_value='',
                              description='rig YAML (intrinsics + extrinsics); required'),
        DeclareLaunchArgument('bag', default_value='', description='bag to play (optional)'),
        DeclareLaunchArgument('rate', default_value='1.0', description='playback rate'),
        DeclareLaunchArgument('loop', default_value='false', description='play the bag again '
                              'and again'),
        DeclareLaunchArgument('mode', default_value='composed',
                              choices=['composed', 'distributed'],
                              description='composed: one tracker process hosting features '
                                          'and salient_points; distributed: three processes'),
        SetEnvironmentVariable('FASTDDS_DEFAULT_PROFILES_FILE',
                               os.path.join(share, 'config', 'fastdds_large_data.xml')),
        node('features', condition=IfCondition(distributed)),
        node('salient_points', condition=IfCondition(distributed)),
        node('tracker', more=[{'rig_file': LaunchConfiguration('rig'), 'inputs': inputs}]),
        node('player', more=[{'bag': LaunchConfiguration('bag'),
                              'playback.rate': LaunchConfiguration('rate'),
                              'playback.loop': LaunchConfiguration('loop')}]),
        node('recorder'),
    ])
