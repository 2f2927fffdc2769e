"""Twin + top-drive controller, the run recorded to MCAP by the twin itself.

``ros2 launch drill_twin drill_twin.launch.py [record_path:=run.mcap] [config:=NAME]
[controller:=soft_torque|z_torque|stability_tuned|stiff_pi]``.
By default the run is recorded to ``$ROS_HOME/drill_twin/drill_twin_<UTC time>.mcap``
(``~/.ros/drill_twin/...``, where ROS keeps its logs: not wherever the user stands);
``record_path:=''`` switches recording off.  The twin's own recorder is used
(simulated log time, set-points at the time they were applied) so that
``drill-twin replay run.mcap --resimulate`` reproduces the run; to record other
topics or another graph, run ``ros2 run drill_twin mcap_recorder``.
``estimator:=true`` also starts ``downhole_estimator`` on the twin's surface topics.
``opcua:=true`` also starts ``opcua_bridge``: the twin as an OPC UA server on
``opcua_endpoint`` (default ``opc.tcp://127.0.0.1:4840/drill_twin/``; docs/opcua.md).
"""
import datetime
import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def default_record_path() -> str:
    """``$ROS_HOME/drill_twin/drill_twin_<UTC time>.mcap`` (ROS_HOME defaults to ~/.ros)."""
    home = os.environ.get('ROS_HOME') or os.path.join(os.path.expanduser('~'), '.ros')
    stamp = datetime.datetime.now(datetime.UTC).strftime('%Y%m%d_%H%M%S')
    return os.path.join(home, 'drill_twin', f'drill_twin_{stamp}.mcap')


def generate_launch_description():
    config = LaunchConfiguration('config')
    return LaunchDescription([
        DeclareLaunchArgument('record_path', default_value=default_record_path(),
                              description="MCAP file of the run ('' = no recording)"),
        DeclareLaunchArgument('config', default_value='rig_fem',
                              description='configuration name or file (units: si)'),
        DeclareLaunchArgument('controller', default_value='soft_torque',
                              description='top_drive_controller mode over topics '
                              '(docs/control.md)'),
        DeclareLaunchArgument('estimator', default_value='false',
                              description='start downhole_estimator beside the twin'),
        DeclareLaunchArgument('opcua', default_value='false',
                              description='start opcua_bridge (OPC UA server) beside the twin'),
        DeclareLaunchArgument('opcua_endpoint',
                              default_value='opc.tcp://127.0.0.1:4840/drill_twin/',
                              description='OPC UA endpoint (not loopback: secured, '
                              'docs/opcua.md)'),
        Node(package='drill_twin', executable='twin_node', name='drill_twin',
             parameters=[{'config': config, 'real_time_factor': 1.0,
                          'record_path': LaunchConfiguration('record_path')}]),
        Node(package='drill_twin', executable='top_drive_controller',
             name='top_drive_controller',
             parameters=[{'config': config, 'control_rate_hz': 100.0,
                          'mode': LaunchConfiguration('controller')}]),
        Node(package='drill_twin', executable='downhole_estimator', name='downhole_estimator',
             parameters=[{'config': config, 'rate_hz': 100.0}],
             condition=IfCondition(LaunchConfiguration('estimator'))),
        Node(package='drill_twin', executable='opcua_bridge', name='opcua_bridge',
             parameters=[{'config': config,
                          'endpoint': LaunchConfiguration('opcua_endpoint')}],
             condition=IfCondition(LaunchConfiguration('opcua'))),
    ])
