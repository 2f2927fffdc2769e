"""``top_drive_controller`` (and its old name ``soft_torque_node``): the top-drive
controller modes over topics (adapter over :mod:`drill_twin.control.external` and the
policy of :class:`drill_twin.runtime.controller.ControllerSupervisor`).

``mode`` (start-up): ``soft_torque`` (default; the §3.2 tuning), ``z_torque``
(impedance matching), ``stability_tuned`` (gains tuned by the stability module at
start-up, seconds) or ``stiff_pi`` (pass-through: the drive's own loop).  Inputs: the
operator's ``surface_speed_setpoint`` [rad/s] and the measured ``surface/torque`` [N m],
each gated (out-of-range, non-finite or unconfirmed jumping samples are refused, logged
and counted; the last accepted value stays).  Until an operator set-point arrives the
controller tracks the operating point of ``config`` (what the twin built from the same
configuration turns at).  Output: ``surface_speed_command`` [rad/s] at
``control_rate_hz``.  Gains are computed from the string in ``config`` (its motor drive
data).  The controller integrates on the node clock, so with ``use_sim_time`` it follows
the twin's ``/clock``.  If torque measurements stop for ``measurement_timeout_s`` the node
commands the operator set-point unchanged and says so (diagnostics WARN + log); it resumes
when measurements return.  A command held at a speed bound is a WARN too.  Every
parameter but ``config`` applies at run time: validated when set, applied after success
(post-set callback).
"""
from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64

from ..control.external import configured_speed, external_controller, mode_drive
from ..runtime.controller import ControllerSupervisor
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
        # the twin built from the same configuration turns at its operating point until an
        # operator set-point arrives: track that from the start, not nothing
        self.policy = ControllerSupervisor(
            self.ctrl, configured_speed(g('config')), g('measurement_timeout_s'),
            max_torque_Nm=g('max_surface_torque_Nm'),
            max_torque_jump_Nm=g('max_torque_jump_Nm'))
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
            f'N m/rad, g_T {gains.torque_feedback_rad_s_Nm:.4g} rad/s/(N m); tracking the '
            f"configured set-point {self.policy.setpoint:g} rad/s of {g('config')} until an "
            'operator set-point arrives')

    @property
    def setpoint(self) -> float:
        """The set-point tracked [rad/s]."""
        return self.policy.setpoint

    @property
    def in_fallback(self) -> bool:
        return self.policy.in_fallback

    @property
    def fallbacks(self) -> int:
        return self.policy.fallbacks

    @property
    def rejected(self) -> int:
        """Set-points refused."""
        return self.policy.rejected_setpoints

    def _param(self, name):
        return self.get_parameter(name).value

    def _on_setpoint(self, msg):
        why = self.policy.on_setpoint(msg.data, time.monotonic())
        if why is not None:
            self.get_logger().warning(f'rejected {why}', throttle_duration_sec=1.0)

    def _on_torque(self, msg):
        why = self.policy.on_torque(msg.data, time.monotonic())
        if why is not None:
            self.get_logger().warning(f'refused surface/torque sample: {why}',
                                      throttle_duration_sec=1.0)

    # --- parameters: validate on set, apply after ------------------------------------
    def _validate_parameters(self, params):
        for prm in params:
            if prm.name == 'max_surface_speed_rad_s' and prm.value < self.setpoint:
                return SetParametersResult(successful=False, reason=(
                    f'max_surface_speed_rad_s {prm.value:g} rad/s is below the set-point '
                    f'{self.setpoint:g} rad/s; lower the set-point first'))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        for prm in params:
            if prm.name == 'enabled':
                self.ctrl.enabled = bool(prm.value) and self.mode != 'stiff_pi'
                if prm.value:
                    self.ctrl.reset(self.setpoint, torque=self.policy.torque.latest)
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
                self.policy.watch.timeout_s = float(prm.value)

    # --- control loop ------------------------------------------------------------------
    def _control(self):
        # the node clock: wall time, or simulated time under use_sim_time (/clock)
        clock_now = self.get_clock().now().nanoseconds * 1e-9
        dt = (clock_now - self._last) if self._last is not None else 0.0
        self._last = clock_now
        if dt <= 0.0:
            dt = 1.0 / self._param('control_rate_hz')
        command, note = self.policy.command(dt, time.monotonic())
        if note is not None:
            self.get_logger().warning(note) if 'not arriving' in note else \
                self.get_logger().info(note)
        self.cmd_pub.publish(Float64(data=float(command)))

    def _diagnostics(self):
        st = DiagnosticStatus(name=f'drill_twin: {self.get_name()}', hardware_id='drill_twin')
        level, message = self.policy.status(time.monotonic())
        st.level = DiagnosticStatus.WARN if level else DiagnosticStatus.OK
        st.message = f'{self.mode}: {message}'
        g = self.drive.gains
        p = self.policy
        st.values = [KeyValue(key='fallbacks', value=str(p.fallbacks)),
                     KeyValue(key='rejected_setpoints', value=str(p.rejected_setpoints)),
                     KeyValue(key='refused_torque_samples', value=str(p.torque.refused)),
                     KeyValue(key='setpoint_rad_s', value=f'{p.setpoint:.6g}'),
                     KeyValue(key='command_rad_s', value='none' if p.command_rad_s is None
                              else f'{p.command_rad_s:.6g}'),
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
