"""``opcua_bridge``: the twin's OPC UA server as a ROS 2 node beside the twin (thin adapter
over :class:`drill_twin.opcua.server.TwinServer`; docs/opcua.md).

The node subscribes to the twin's stamped measurement topics (``joint_states``,
``bit/penetration``, ``bit/stick_slip``), the estimator's, the stability advisory, the
set-point topics and ``/diagnostics``, and fills the OPC UA variables with their values
and the twin's stamps as source timestamps.  A client's accepted set-point is published
on the twin's set-point topic (``surface_speed_setpoint``, ``hook_load_setpoint``,
``block_velocity_setpoint``: the twin's own validation and :class:`SpeedArbiter` apply
to it as to any operator set-point); ``Reset``, ``Pause`` and ``StartScenario`` call the
twin's services.  Who holds control of each function, and each safe state, is published
on ``/diagnostics`` (status ``drill_twin: opcua``).

The server runs in a thread with its own asyncio loop; the ROS executor is never blocked
by a client.
"""
from __future__ import annotations

import asyncio
import math

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistWithCovarianceStamped, Vector3Stamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64
from std_srvs.srv import SetBool, Trigger

from .. import topics as T
from ..config.scenario import load_scenario
from ..opcua.address_space import variables
from ..opcua.server import TwinServer
from ..runtime.settings import OPCUA_SETTINGS
from .common import declare_settings, run_node, warn_unknown_overrides
from .messages import qos_profile, to_message

__all__ = ['OpcUaBridge', 'main', 'DIAGNOSTICS_NAME']

#: the bridge's status in /diagnostics
DIAGNOSTICS_NAME = 'drill_twin: opcua'
#: the twin's status in /diagnostics
TWIN_STATUS = 'drill_twin: model'
SERVICE_TIMEOUT_S = 5.0
_SETPOINTS = ('surface_speed_setpoint', 'hook_load_setpoint', 'block_velocity_setpoint',
              'torque_limit_setpoint')


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class OpcUaBridge(Node):
    """The bridge node (see module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('opcua_bridge', **kwargs)
        declare_settings(self, OPCUA_SETTINGS)
        warn_unknown_overrides(self)
        g = self._param
        scenario = load_scenario(g('config'), [], label='opcua_bridge config:')
        weight = scenario.system.buoyed_weight_N(scenario.system.mud_density_kg_m3)
        has_block = (scenario.raw['model'].get('axial_top') or 'hook_load') in ('hoist',
                                                                                'velocity')
        speed = scenario.groups.omega_o / scenario.scales.time_s
        hook = 0.0 if has_block else weight - scenario.groups.W_o * scenario.scales.force_N
        drive = getattr(scenario.model, 'top_drive', None)
        rated = g('max_torque_Nm') if drive is None else drive.torque_limit_Nm
        table = variables(g('max_surface_speed_rad_s'), weight, has_block, rated,
                          min(speed, g('max_surface_speed_rad_s')), hook, drive is not None)
        sensor, latched = qos_profile(T.SENSOR), qos_profile(T.SETPOINT)
        self.pub = {name: self.create_publisher(Float64, name, latched) for name in _SETPOINTS}
        self.diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics',
                                                 qos_profile(T.EVENTS))
        twin = g('twin_node').strip('/')
        self.twin_services = {'reset': self.create_client(Trigger, f'/{twin}/reset'),
                        'pause': self.create_client(SetBool, f'/{twin}/pause'),
                        'start_scenario': self.create_client(Trigger,
                                                             f'/{twin}/start_scenario')}
        self.server = TwinServer(g('endpoint'), self, table, g('security_dir') or None,
                                 g('max_refresh_delay_s'), has_block)
        self.server.start()
        self._estimate_stamp = None
        subscribe = self.create_subscription
        subscribe(JointState, 'joint_states', self._on_joints, sensor)
        subscribe(Float64, 'surface/motor_torque', lambda m: self.server.update(
            {'Rotation.MotorTorque': m.data}, None), sensor)
        subscribe(Vector3Stamped, 'bit/penetration', self._on_penetration, sensor)
        subscribe(Vector3Stamped, 'bit/stick_slip', self._on_stick_slip, sensor)
        subscribe(TwistWithCovarianceStamped, 'estimate/bit/velocity', self._on_est_velocity,
                  sensor)
        subscribe(WrenchStamped, 'estimate/bit/wrench', self._on_est_wrench, sensor)
        subscribe(Bool, 'estimate/bit/stuck', lambda m: self._estimate(
            {'Estimate.Stuck': bool(m.data)}), sensor)
        subscribe(Float64, 'estimate/stick_slip_severity', lambda m: self._estimate(
            {'Estimate.StickSlipSeverity': m.data}), sensor)
        subscribe(Float64, 'stability/spectral_abscissa', lambda m: self.server.update(
            {'Stability.SpectralAbscissa': m.data}, None), latched)
        subscribe(Float64, 'stability/critical_surface_speed', lambda m: self.server.update(
            {'Stability.CriticalSpeed': m.data}, None), latched)
        for name in _SETPOINTS:
            subscribe(Float64, name, lambda m, n=name: self.server.ros_setpoint(n, m.data),
                      latched)
        subscribe(DiagnosticArray, '/diagnostics', self._on_diagnostics, qos_profile(T.EVENTS))
        self.create_timer(1.0, self._publish_diagnostics)
        security = 'none (loopback: local anonymous clients may write)' if self.server.local \
            else 'Basic256Sha256 SignAndEncrypt, users and trusted certificates'
        self.get_logger().info(f'OPC UA server on {g("endpoint")} (namespace urn:drill_twin, '
                               f'security: {security})')

    def _param(self, name):
        return self.get_parameter(name).value

    # --- measurements -------------------------------------------------------------------
    def _on_joints(self, msg):
        index = {name: i for i, name in enumerate(msg.name)}
        try:
            p = {n: msg.position[index[n]] for n in T.JOINTS}
            v = {n: msg.velocity[index[n]] for n in T.JOINTS}
            e = {n: msg.effort[index[n]] for n in T.JOINTS}
        except (KeyError, IndexError):
            return
        self.server.update({
            'Rotation.Measured': v['top_drive'], 'Rotation.SurfaceTorque': e['top_drive'],
            'Hoisting.HookLoad': e['block'], 'Hoisting.BlockVelocity': v['block'],
            'Hoisting.BlockPosition': p['block'], 'Bit.AngularSpeed': v['bit'],
            'Bit.AxialSpeed': v['bit_axial'], 'Bit.WeightOnBit': e['bit_axial'],
            'Bit.TorqueOnBit': e['bit'], 'Bit.Depth': p['bit_axial']},
            _ns(msg.header.stamp))

    def _on_penetration(self, msg):
        self.server.update({'Bit.DepthOfCut': msg.vector.x, 'Bit.HeightAboveBottom':
                            msg.vector.y, 'Bit.RateOfPenetration': msg.vector.z},
                           _ns(msg.header.stamp))

    def _on_stick_slip(self, msg):
        self.server.update({'Bit.StickSlipSeverity': msg.vector.x,
                            'Bit.Stuck': msg.vector.y > 0.5}, _ns(msg.header.stamp))

    def _on_est_velocity(self, msg):
        self._estimate_stamp = _ns(msg.header.stamp)
        cov = msg.twist.covariance
        self._estimate({'Estimate.BitAngularSpeed': msg.twist.twist.angular.x,
                        'Estimate.BitAngularSpeedStd': math.sqrt(max(cov[21], 0.0)),
                        'Estimate.BitAxialSpeed': msg.twist.twist.linear.x,
                        'Estimate.BitAxialSpeedStd': math.sqrt(max(cov[0], 0.0))})

    def _on_est_wrench(self, msg):
        self._estimate_stamp = _ns(msg.header.stamp)
        self._estimate({'Estimate.WeightOnBit': msg.wrench.force.x,
                        'Estimate.TorqueOnBit': msg.wrench.torque.x})

    def _estimate(self, values):
        self.server.update(values, self._estimate_stamp)

    def _on_diagnostics(self, msg):
        for status in msg.status:
            if status.name == TWIN_STATUS:
                self.server.twin_health(int.from_bytes(status.level, 'little')
                                        if isinstance(status.level, bytes)
                                        else int(status.level), status.message)

    # --- the plant interface of TwinServer (called from the server's thread) -------------
    def setpoint(self, topic: str, value: float):
        self.pub[topic].publish(Float64(data=float(value)))

    def log(self, level: str, line: str):
        if self.context.ok():
            getattr(self.get_logger(), level)(line)

    def control_changed(self, function: str, client: str, reason: str):
        if self.context.ok():
            self._publish_diagnostics()

    async def call(self, service: str, argument=None) -> tuple:
        client = self.twin_services[service]
        if not client.service_is_ready():
            return False, f'{client.srv_name} is not available (is the twin running?)'
        request = client.srv_type.Request()
        if service == 'pause':
            request.data = bool(argument)
        loop = asyncio.get_running_loop()
        answer = loop.create_future()

        def done(future):
            loop.call_soon_threadsafe(lambda: answer.done() or answer.set_result(future))
        client.call_async(request).add_done_callback(done)
        try:
            future = await asyncio.wait_for(answer, SERVICE_TIMEOUT_S)
        except TimeoutError:
            return False, f'{client.srv_name} did not answer within {SERVICE_TIMEOUT_S:g} s'
        response = future.result()
        return bool(response.success), str(response.message)

    # --- /diagnostics -------------------------------------------------------------------
    def _publish_diagnostics(self):
        level, message = self.server.status()
        s = self.server
        values = {'endpoint': s.endpoint,
                  'security': 'loopback, no security' if s.local else
                  'Basic256Sha256 SignAndEncrypt',
                  'rotation_control': s.arbiter.holder('rotation') or 'operator',
                  'hoisting_control': s.arbiter.holder('hoisting') or 'operator',
                  'rejected_writes': s.rejected, 'safe_states': s.safe_states}
        stamp = T.stamp_fields(ns=self.get_clock().now().nanoseconds)
        self.diagnostics.publish(to_message(DiagnosticArray, T.diagnostics_fields(
            stamp, level, message, values, name=DIAGNOSTICS_NAME)))

    def destroy_node(self):
        self.server.stop()
        return super().destroy_node()


def main(args=None):
    return run_node(OpcUaBridge, 'opcua_bridge', args)


if __name__ == '__main__':
    raise SystemExit(main())
