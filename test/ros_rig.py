"""In-process ROS test rig: one context, one executor, a probe node; spin until a condition
or a deadline (no sleeps as synchronisation)."""
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64

from drill_twin.ros.twin_node import SETPOINT_QOS, TwinNode


class Rig:
    """A context with the nodes under test and a probe node."""

    def __init__(self):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.nodes = []
        self.probe = self.add(rclpy.create_node('probe', context=self.ctx))
        self.data = {}

    def add(self, node):
        self.nodes.append(node)
        self.ex.add_node(node)
        return node

    def twin(self, **params):
        """A twin node in this rig: 5x real time, no stability advisor, unless ``params``
        say otherwise."""
        base = {'real_time_factor': 5.0, 'stability_period_s': 0.0}
        base.update(params)
        return self.add(TwinNode(context=self.ctx, parameter_overrides=[
            Parameter(k, value=v) for k, v in base.items()]))

    def call(self, srv_type, name, request, timeout=10):
        """Call a service from the probe; the response (asserts it came within
        ``timeout`` seconds)."""
        client = self.probe.create_client(srv_type, name)
        assert self.spin_until(client.service_is_ready, 10)
        future = client.call_async(request)
        assert self.spin_until(future.done, timeout)
        return future.result()

    def listen(self, topic, msg_type, extract, qos=qos_profile_sensor_data):
        self.data[topic] = []
        self.probe.create_subscription(msg_type, topic,
                                       lambda m: self.data[topic].append(extract(m)), qos)

    def publisher(self, topic):
        return self.probe.create_publisher(Float64, topic, SETPOINT_QOS)

    def spin_until(self, condition, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.ex.spin_once(timeout_sec=0.01)
            if condition():
                return True
        return False

    def close(self):
        self.ex.shutdown()
        for n in self.nodes:
            n.destroy_node()
        rclpy.shutdown(context=self.ctx)
