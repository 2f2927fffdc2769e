"""Twin and Soft-Torque controller as two separate processes talking over DDS (loopback)."""
import os
import random
import signal
import subprocess
import sys
import time

import pytest

rclpy = pytest.importorskip('rclpy')
from geometry_msgs.msg import TwistStamped  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from drill_twin.io.mcap_reader import open_recording  # noqa: E402
from drill_twin.ros.twin_node import COMMAND_QOS, SETPOINT_QOS  # noqa: E402


def _start(module, domain, *params):
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED='1')
    args = [sys.executable, '-m', module, '--ros-args']
    for p in params:
        args += ['-p', p]
    return subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


@pytest.mark.slow
def test_twin_and_controller_in_two_processes(tmp_path):
    """Also: the twin records itself and SIGTERM (what launch and systemd send) closes the
    file properly."""
    domain = random.randint(20, 200)
    saved = os.environ.get('ROS_DOMAIN_ID')
    os.environ['ROS_DOMAIN_ID'] = str(domain)
    record = tmp_path / 'run.mcap'
    procs = [_start('drill_twin.ros.twin_node', domain, 'real_time_factor:=2.0',
                    'stability_period_s:=0.0', f'record_path:={record}'),
             _start('drill_twin.ros.soft_torque_node', domain, 'control_rate_hz:=100.0')]
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('probe', context=ctx)
    got = {'cmd': [], 'bit': [], 'top': []}
    node.create_subscription(Float64, 'surface_speed_command',
                             lambda m: got['cmd'].append(m.data), COMMAND_QOS)
    node.create_subscription(TwistStamped, 'bit/velocity',
                             lambda m: got['bit'].append(m.twist.angular.x),
                             qos_profile_sensor_data)
    node.create_subscription(Float64, 'surface/top_drive_speed',
                             lambda m: got['top'].append(m.data), qos_profile_sensor_data)
    pub = node.create_publisher(Float64, 'surface_speed_setpoint', SETPOINT_QOS)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (len(got['cmd']) > 200 and
                                                   len(got['bit']) > 200):
            pub.publish(Float64(data=12.57))  # transient-local: late joiners get it too
            ex.spin_once(timeout_sec=0.05)
        assert len(got['cmd']) > 200, 'no commands from the controller process'
        assert len(got['bit']) > 200, 'no measurements from the twin process'
        # the twin's top drive follows the controller's command (stiff speed drive)
        recent_cmd = got['cmd'][-50:]
        assert min(recent_cmd) - 0.5 < got['top'][-1] < max(recent_cmd) + 0.5
        assert all(0.0 <= w < 60.0 for w in got['bit'])
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
        if saved is None:
            os.environ.pop('ROS_DOMAIN_ID', None)
        else:
            os.environ['ROS_DOMAIN_ID'] = saved
        procs[0].send_signal(signal.SIGTERM)
        procs[1].send_signal(signal.SIGINT)
        for p in procs:
            try:
                out, _ = p.communicate(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                out, _ = p.communicate()
            assert p.returncode == 0, out[-2000:]
    rec = open_recording(record)  # complete (summary + footer), no recovery needed
    assert rec.message_counts['/surface_speed_command'] > 100
    assert rec.message_counts['/bit/velocity'] > 200
