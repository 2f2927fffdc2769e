"""``soft_torque_node``: Soft-Torque stick-slip controller over topics (adapter over
:class:`drill_twin.physics.soft_torque.SoftTorqueController`).

Inputs: the operator's ``surface_speed_setpoint`` [rad/s] and the measured
``surface/torque`` [N m] (and ``surface/top_drive_speed`` for the start-up
state).  Output: ``surface_speed_command`` [rad/s] at ``control_rate_hz``.
Tuning (I_DS, k_f, c_f, ξ_opt) is computed from the string in ``config``.
The controller integrates on the node clock, so with ``use_sim_time`` it
follows the twin's ``/clock``.
If torque measurements stop for ``measurement_timeout_s`` the node commands
the operator set-point unchanged and says so (diagnostics + log); it resumes
when measurements return.  ``enabled`` switches the controller at run time.
"""
from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64

from ..physics.parameters import ParameterError
from ..physics.scenario import load_scenario
from ..physics.soft_torque import SoftTorqueController, soft_torque_si
from .common import float_range, run_node
from .twin_node import COMMAND_QOS, SETPOINT_QOS

__all__ = ['SoftTorqueNode', 'main']


class SoftTorqueNode(Node):
    """The Soft-Torque controller node (see module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('soft_torque', **kwargs)
        p = self.declare_parameter
        p('config', 'benchmark_fem', ParameterDescriptor(
            description='string configuration the tuning is computed from (SI)'))
        p('control_rate_hz', 100.0, float_range(1.0, 5000.0, 'command rate [Hz]'))
        p('enabled', True, ParameterDescriptor(description='Soft-Torque on/off'))
        p('max_surface_speed_rad_s', 40.0, float_range(0.1, 100.0, 'command upper bound'))
        p('max_acceleration_rad_s2', 20.0, float_range(0.01, 1000.0, 'command rate limit'))
        p('measurement_timeout_s', 0.5, float_range(0.01, 60.0, 'torque silence before fallback'))
        p('torque_filter_s', 1000.0, float_range(0.1, 1e6, 'reference-torque low-pass [s]'))
        g = self.get_parameter
        scenario = load_scenario(g('config').value)
        if not scenario.is_si:
            raise ParameterError('soft_torque_node needs an SI configuration')
        self.tuning = soft_torque_si(scenario.system)
        self.ctrl = SoftTorqueController(
            self.tuning['inertia'], self.tuning['stiffness'], self.tuning['damping'],
            max_speed_rad_s=g('max_surface_speed_rad_s').value,
            max_accel_rad_s2=g('max_acceleration_rad_s2').value,
            torque_filter_s=g('torque_filter_s').value)
        self.ctrl.enabled = g('enabled').value
        self.setpoint = None
        self.torque = None
        self.torque_time = None
        self.fallbacks = 0
        self.in_fallback = False
        self.create_subscription(Float64, 'surface_speed_setpoint', self._on_setpoint,
                                 SETPOINT_QOS)
        self.create_subscription(Float64, 'surface/torque', self._on_torque,
                                 qos_profile_sensor_data)
        self.cmd_pub = self.create_publisher(Float64, 'surface_speed_command', COMMAND_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._last = None
        self._timer = self.create_timer(1.0 / g('control_rate_hz').value, self._control)
        self.create_timer(1.0, self._diagnostics)
        self.add_on_set_parameters_callback(self._on_parameters)
        self.get_logger().info(
            'Soft-Torque tuned: I_DS {inertia:.0f} kg m2, k_f {stiffness:.0f} N m/rad, '
            'c_f {damping:.0f} N m s/rad, xi_opt {xi_opt:.3f}'.format(**self.tuning))

    def _on_setpoint(self, msg):
        if msg.data != msg.data or not 0.0 <= msg.data <= self.ctrl.max_speed:
            self.get_logger().warning(f'rejected set-point {msg.data}')
            return
        self.setpoint = msg.data

    def _on_torque(self, msg):
        if msg.data == msg.data:  # NaN measurements are ignored
            self.torque = msg.data
            self.torque_time = time.monotonic()

    def _on_parameters(self, params):
        for prm in params:
            if prm.name == 'enabled':
                self.ctrl.enabled = bool(prm.value)
                if prm.value and self.setpoint is not None:
                    self.ctrl.reset(self.setpoint, torque=self.torque)
            elif prm.name == 'control_rate_hz':
                self._timer.cancel()
                self._timer = self.create_timer(1.0 / prm.value, self._control)
            elif prm.name == 'config':
                return SetParametersResult(successful=False,
                                           reason='config only takes effect at start-up')
        return SetParametersResult(successful=True)

    def _control(self):
        if self.setpoint is None:
            return  # nothing to track yet
        # the node clock: wall time, or simulated time under use_sim_time (/clock)
        clock_now = self.get_clock().now().nanoseconds * 1e-9
        dt = (clock_now - self._last) if self._last is not None else 0.0
        self._last = clock_now
        if dt <= 0.0:
            dt = 1.0 / self.get_parameter('control_rate_hz').value
        now = time.monotonic()
        stale = self.torque_time is None or \
            now - self.torque_time > self.get_parameter('measurement_timeout_s').value
        if stale:
            if not self.in_fallback:
                self.fallbacks += 1
                self.get_logger().warning('surface torque not arriving: holding the operator '
                                          'set-point')
            self.in_fallback = True
            self.ctrl.reset(self.setpoint, torque=self.torque)
            command = self.setpoint
        else:
            if self.in_fallback:
                self.get_logger().info('surface torque back: Soft-Torque resumes')
                self.in_fallback = False
            command = self.ctrl.update(dt, self.setpoint, self.torque)
        self.cmd_pub.publish(Float64(data=float(command)))

    def _diagnostics(self):
        st = DiagnosticStatus(name='drill_twin: soft_torque', hardware_id='drill_twin')
        if self.in_fallback:
            st.level, st.message = DiagnosticStatus.WARN, 'no torque measurement: holding set-point'
        else:
            st.level = DiagnosticStatus.OK
            st.message = 'enabled' if self.ctrl.enabled else 'disabled'
        st.values = [KeyValue(key='fallbacks', value=str(self.fallbacks)),
                     KeyValue(key='xi_opt', value=f"{self.tuning['xi_opt']:.4f}")]
        arr = DiagnosticArray(status=[st])
        arr.header.stamp = self.get_clock().now().to_msg()
        self.diag_pub.publish(arr)


def main(args=None):
    return run_node(SoftTorqueNode, 'soft_torque_node', args)


if __name__ == '__main__':
    raise SystemExit(main())
