"""Twin + Soft-Torque controller (recorder: added with the MCAP issue)."""
from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description():
    return LaunchDescription([
        Node(package='drill_twin', executable='twin_node', name='drill_twin',
             parameters=[{'config': 'benchmark_fem', 'real_time_factor': 1.0}]),
        Node(package='drill_twin', executable='soft_torque_node', name='soft_torque',
             parameters=[{'config': 'benchmark_fem', 'control_rate_hz': 100.0}]),
    ])
