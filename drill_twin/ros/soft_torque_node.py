"""``top_drive_controller`` (and its old name ``soft_torque_node``): the top-drive
controller modes over topics (adapter over :mod:`drill_twin.control.external`).

``mode`` (start-up): ``soft_torque`` (default; the §3.2 tuning), ``z_torque``
(impedance matching), ``stability_tuned`` (gains tuned by the stability module at
start-up, seconds) or ``stiff_pi`` (pass-through: the drive's own loop).  Inputs: the
operator's ``surface_speed_setpoint`` [rad/s] and the measured ``surface/torque`` [N m].
Output: ``surface_speed_command`` [rad/s] at ``control_rate_hz``.  Gains are computed
from the string in ``config`` (its motor drive data).  The controller integrates on the
node clock, so with ``use_sim_time`` it follows the twin's ``/clock``.
If torque measurements stop for ``measurement_timeout_s``
(:class:`~drill_twin.runtime.arbitration.Watchdog`) the node commands the
operator set-point unchanged and says so (diagnostics + log); it resumes when
measurements return.  Every parameter but ``config`` applies at run time:
validated when set, applied after success (post-set callback).
"""
from __future__ import annotations

import math
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64

from ..control.external import external_controller, mode_drive
from ..runtime.arbitration import Watchdog
from ..runtime.settings import CONTROLLER_SETTINGS
from .common import declare_settings, run_node, warn_unknown_overrides
from .twin_node import COMMAND_QOS, SETPOINT_QOS

__all__ = ['TopDriveControllerNode', 'SoftTorqueNode', 'main', 'main_top_drive_controller']


class TopDriveControllerNode(Node):
    """The top-drive controller node (see module docstring)."""

    def __init__(self, node_name='top_drive_controller', **kwargs):
        super().__init__(node_name, **kwargs)
        declare_settings(self, CONTROLLER_SETTINGS)
        warn_unknown_overrides(self)
        g = self._param
        self.mode = g('mode')
        self.drive = mode_drive(self.mode, g('config'))
        self.ctrl = external_controller(
            self.drive, max_speed_rad_s=g('max_surface_speed_rad_s'),
            max_accel_rad_s2=g('max_acceleration_rad_s2'),
            torque_filter_s=g('torque_filter_s'))
        self.ctrl.enabled = g('enabled') and self.mode != 'stiff_pi'
        self.setpoint = None
        self.torque = None
        self.torque_watch = Watchdog(g('measurement_timeout_s'))
        self.fallbacks = 0
        self.in_fallback = False
        self.rejected = 0
        self.create_subscription(Float64, 'surface_speed_setpoint', self._on_setpoint,
                                 SETPOINT_QOS)
        self.create_subscription(Float64, 'surface/torque', self._on_torque,
                                 qos_profile_sensor_data)
        self.cmd_pub = self.create_publisher(Float64, 'surface_speed_command', COMMAND_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._last = None
        self._timer = self.create_timer(1.0 / g('control_rate_hz'), self._control)
        self.create_timer(1.0, self._diagnostics)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        gains = self.drive.gains
        self.get_logger().info(
            f'{self.mode}: J {self.drive.motor_inertia_kgm2:.0f} kg m2, K_p '
            f'{gains.proportional_Nms_rad:.4g} N m s/rad, K_i {gains.integral_Nm_rad:.4g} '
            f'N m/rad, g_T {gains.torque_feedback_rad_s_Nm:.4g} rad/s/(N m)')

    def _param(self, name):
        return self.get_parameter(name).value

    def _on_setpoint(self, msg):
        value = msg.data
        if not (math.isfinite(value) and 0.0 <= value <= self.ctrl.max_speed):
            self.rejected += 1
            self.get_logger().warning(
                f'rejected set-point {value} rad/s: outside [0, {self.ctrl.max_speed:g}] rad/s; '
                f'keeping {self.setpoint}')
            return
        self.setpoint = value

    def _on_torque(self, msg):
        if math.isfinite(msg.data):  # non-finite measurements are ignored
            self.torque = msg.data
            self.torque_watch.feed(time.monotonic())

    # --- parameters: validate on set, apply after ------------------------------------
    def _validate_parameters(self, params):
        for prm in params:
            if prm.name == 'max_surface_speed_rad_s' and self.setpoint is not None \
                    and prm.value < self.setpoint:
                return SetParametersResult(successful=False, reason=(
                    f'max_surface_speed_rad_s {prm.value:g} rad/s is below the set-point '
                    f'{self.setpoint:g} rad/s; lower the set-point first'))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        for prm in params:
            if prm.name == 'enabled':
                self.ctrl.enabled = bool(prm.value) and self.mode != 'stiff_pi'
                if prm.value and self.setpoint is not None:
                    self.ctrl.reset(self.setpoint, torque=self.torque)
            elif prm.name == 'control_rate_hz':
                self._timer.cancel()
                self.destroy_timer(self._timer)
                self._timer = self.create_timer(1.0 / prm.value, self._control)
            elif prm.name == 'max_surface_speed_rad_s':
                self.ctrl.max_speed = float(prm.value)
            elif prm.name == 'max_acceleration_rad_s2':
                self.ctrl.max_accel = float(prm.value)
            elif prm.name == 'torque_filter_s':
                self.ctrl.torque_filter_s = float(prm.value)
            elif prm.name == 'measurement_timeout_s':
                self.torque_watch.timeout_s = float(prm.value)

    # --- control loop ------------------------------------------------------------------
    def _control(self):
        if self.setpoint is None:
            return  # nothing to track yet
        # the node clock: wall time, or simulated time under use_sim_time (/clock)
        clock_now = self.get_clock().now().nanoseconds * 1e-9
        dt = (clock_now - self._last) if self._last is not None else 0.0
        self._last = clock_now
        if dt <= 0.0:
            dt = 1.0 / self._param('control_rate_hz')
        if self.torque_watch.expired(time.monotonic()):  # it was arriving, and stopped
            self.fallbacks += 1
            self.get_logger().warning('surface torque not arriving: holding the operator '
                                      'set-point')
        if self.torque_watch.silent:
            self.in_fallback = True
            self.ctrl.reset(self.setpoint, torque=self.torque)
            command = self.setpoint
        else:
            if self.in_fallback:
                self.get_logger().info(f'surface torque back: {self.mode} resumes')
                self.in_fallback = False
            command = self.ctrl.update(dt, self.setpoint, self.torque)
        self.cmd_pub.publish(Float64(data=float(command)))

    def _diagnostics(self):
        st = DiagnosticStatus(name=f'drill_twin: {self.get_name()}', hardware_id='drill_twin')
        if self.in_fallback:
            st.level = DiagnosticStatus.WARN
            st.message = ('surface torque stopped: holding the set-point' if
                          self.torque_watch.last_s is not None else
                          'no surface torque yet: holding the set-point')
        else:
            st.level = DiagnosticStatus.OK
            st.message = f'{self.mode} enabled' if self.ctrl.enabled else \
                f'{self.mode}: passing the set-point'
        g = self.drive.gains
        st.values = [KeyValue(key='fallbacks', value=str(self.fallbacks)),
                     KeyValue(key='rejected_setpoints', value=str(self.rejected)),
                     KeyValue(key='mode', value=self.mode),
                     KeyValue(key='proportional_gain_Nms_rad',
                              value=f'{g.proportional_Nms_rad:.6g}'),
                     KeyValue(key='integral_gain_Nm_rad', value=f'{g.integral_Nm_rad:.6g}'),
                     KeyValue(key='torque_feedback_rad_s_Nm',
                              value=f'{g.torque_feedback_rad_s_Nm:.6g}')]
        arr = DiagnosticArray(status=[st])
        arr.header.stamp = self.get_clock().now().to_msg()
        self.diag_pub.publish(arr)


class SoftTorqueNode(TopDriveControllerNode):
    """The controller under its first name (node ``soft_torque``, mode soft_torque by
    default): ``ros2 run drill_twin soft_torque_node`` keeps working."""

    def __init__(self, **kwargs):
        super().__init__('soft_torque', **kwargs)


def main(args=None):
    return run_node(SoftTorqueNode, 'soft_torque_node', args)


def main_top_drive_controller(args=None):
    return run_node(TopDriveControllerNode, 'top_drive_controller', args)


if __name__ == '__main__':
    raise SystemExit(main())
