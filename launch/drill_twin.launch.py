"""Twin + Soft-Torque controller, the run recorded to MCAP by the twin itself.

``ros2 launch drill_twin drill_twin.launch.py [record_path:=run.mcap]``;
``record_path:=''`` switches recording off.  The twin's own recorder is used
(simulated log time, set-points at the time they were applied) so that
``drill-twin replay run.mcap --resimulate`` reproduces the run; to record other
topics or another graph, run ``ros2 run drill_twin mcap_recorder``.
"""
import datetime

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    stamp = datetime.datetime.now(datetime.UTC).strftime('%Y%m%d_%H%M%S')
    return LaunchDescription([
        DeclareLaunchArgument('record_path', default_value=f'drill_twin_{stamp}.mcap',
                              description="MCAP file of the run ('' = no recording)"),
        Node(package='drill_twin', executable='twin_node', name='drill_twin',
             parameters=[{'config': 'benchmark_fem', 'real_time_factor': 1.0,
                          'record_path': LaunchConfiguration('record_path')}]),
        Node(package='drill_twin', executable='soft_torque_node', name='soft_torque',
             parameters=[{'config': 'benchmark_fem', 'control_rate_hz': 100.0}]),
    ])
