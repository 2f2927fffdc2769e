"""``twin_node``: the drilling digital twin as a ROS 2 node (thin adapter over
:class:`drill_twin.physics.digital_twin.DigitalTwin`).

Time: a wall-clock timer advances the model to ``(now - start) * real_time_factor``
(steady clock, so it never drifts; catching up is capped per tick and counted
as an overrun).  With ``as_fast_as_possible`` it runs unthrottled and
publishes ``/clock`` so that other nodes can follow simulated time.

Speed precedence: a ``surface_speed_command`` (from the Soft-Torque controller)
drives the motor while such commands keep arriving (within
``command_timeout_s``); otherwise the operator's ``surface_speed_setpoint``
does.  The controller tracks the operator set-point itself, so this lets it
act, and falls back safely to the operator when it goes silent.
Recording: with ``record_path`` the twin writes its own run to MCAP
(:class:`drill_twin.io.run_recorder.TwinRecorder`: simulated log time,
set-points at the simulated time they were applied), which
``drill-twin replay --resimulate`` reproduces exactly.
Topics, units, frames and QoS: see the README (the table is
:data:`drill_twin.topics.TOPICS`).
"""
from __future__ import annotations

import threading
import time

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from std_msgs.msg import Float64

from .. import topics as T
from ..io.run_recorder import TwinRecorder
from ..physics.digital_twin import DigitalTwin, SetpointError
from ..physics.parameters import ParameterError
from ..physics.scenario import load_scenario
from .common import float_range, run_node
from .messages import message_class, qos_profile, to_message

__all__ = ['TwinNode', 'main', 'SETPOINT_QOS', 'LATCHED_QOS']

#: set-points the twin must not miss (REP-2003: reliable, transient local)
SETPOINT_QOS = qos_profile(T.SETPOINT)
#: low-rate advisories a late joiner should still get
LATCHED_QOS = SETPOINT_QOS
#: controller commands: reliable, volatile (a stale command must not be replayed)
COMMAND_QOS = qos_profile(T.COMMAND)

_RESTART_ONLY = ('config', 'overrides', 'drive_time_constant_s', 'mud_density_kg_m3',
                 'as_fast_as_possible', 'record_path', 'record_chunk_period_s')


class TwinNode(Node):
    """The twin node (see module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('drill_twin', **kwargs)
        p = self.declare_parameter
        p('config', 'benchmark_fem', ParameterDescriptor(
            description='configuration file or name in share/drill_twin/config (SI)'))
        p('overrides', [''], ParameterDescriptor(description='KEY=VALUE config overrides'))
        p('real_time_factor', 1.0, float_range(0.01, 1000.0, 'simulated seconds per wall second'))
        p('publish_rate_hz', 100.0, float_range(1.0, 2000.0, 'measurement publish rate [Hz]'))
        p('drive_time_constant_s', 0.0, float_range(0.0, 10.0, 'speed-drive lag [s], 0 = stiff'))
        p('mud_density_kg_m3', 1200.0, float_range(0.0, 3000.0, 'mud density [kg/m^3]'))
        p('max_surface_speed_rad_s', 40.0, float_range(0.1, 100.0, 'largest accepted set-point'))
        p('command_timeout_s', 0.5, float_range(0.01, 60.0, 'controller command validity [s]'))
        p('stability_period_s', 30.0, float_range(0.0, 3600.0, 'stability advisory period, 0=off'))
        p('as_fast_as_possible', False, ParameterDescriptor(
            description='run unthrottled and publish /clock'))
        p('record_path', '', ParameterDescriptor(
            description='record the run to this .mcap file (simulated log time), "" = off'))
        p('record_chunk_period_s', 0.25, float_range(
            0.01, 10.0, 'longest span one MCAP chunk holds = most data a kill can lose [s]'))
        g = self.get_parameter
        overrides = [o for o in g('overrides').value if o]
        self.twin = DigitalTwin(load_scenario(g('config').value, overrides),
                                mud_density_kg_m3=g('mud_density_kg_m3').value,
                                drive_time_constant_s=g('drive_time_constant_s').value,
                                max_surface_speed_rad_s=g('max_surface_speed_rad_s').value)
        self.operator_speed = self.twin.surface_speed_setpoint
        self.last_command_time = None
        self.overruns = 0
        self.blow_up = ''
        self.advisory = None
        self._last_measurements = None  # of the latest tick (measurements() feeds a window)
        self._lock = threading.Lock()

        self.create_subscription(Float64, 'surface_speed_setpoint', self._on_speed, SETPOINT_QOS)
        self.create_subscription(Float64, 'hook_load_setpoint', self._on_hook_load, SETPOINT_QOS)
        self.create_subscription(Float64, 'surface_speed_command', self._on_command, COMMAND_QOS)
        self.pub = {t.name: (message_class(t.type), self.create_publisher(
            message_class(t.type), t.name, qos_profile(t.qos)))
            for t in T.TOPICS if t.role in ('measurement', 'advisory', 'diagnostics')}
        self.recorder = None
        if g('record_path').value:
            self.recorder = TwinRecorder(
                g('record_path').value, self.twin, g('config').value, overrides,
                namespace=self.get_namespace(), chunk_period_s=g('record_chunk_period_s').value,
                settings={'publish_rate_hz': g('publish_rate_hz').value,
                          'real_time_factor': g('real_time_factor').value,
                          'as_fast_as_possible': g('as_fast_as_possible').value,
                          'source': 'twin_node'})
            self.create_timer(g('record_chunk_period_s').value, self.recorder.flush)
        self.fast = g('as_fast_as_possible').value
        if self.fast:
            clock = T.BY_NAME['/clock']
            self.pub[clock.name] = (message_class(clock.type), self.create_publisher(
                message_class(clock.type), clock.name, qos_profile(clock.qos)))
        self.add_on_set_parameters_callback(self._on_parameters)
        self._start_wall = None  # anchored at the first tick (start-up cost is not an overrun)
        self._start_sim = self.twin.time_s
        self._timer = self.create_timer(0.0 if self.fast else 1.0 / g('publish_rate_hz').value,
                                        self._tick)
        self.create_timer(1.0, self._publish_diagnostics)
        self._stop = threading.Event()
        self._advisor = None
        if g('stability_period_s').value > 0:
            self._advisor = threading.Thread(target=self._advise, daemon=True)
            self._advisor.start()
        self.get_logger().info(
            f'twin of {self.twin.scenario.model.name} running, step {self.twin.step_s:.2e} s, '
            f'hook load {self.twin.hook_load_N:.0f} N, surface speed '
            f'{self.twin.surface_speed_setpoint:.2f} rad/s')

    # --- inputs ----------------------------------------------------------------------
    def _send(self, name, fields, time_s=None):
        """Publish on a topic of the interface table and record it."""
        cls, pub = self.pub[name]
        if self.recorder is not None:
            self.recorder.event(name, fields, time_s)
        pub.publish(to_message(cls, fields))

    def _apply_speed(self, value, source):
        """Apply a speed set-point or command; ``source`` is its topic (recorded as such;
        the return to the operator set-point is recorded as ``surface_speed_setpoint``)."""
        try:
            with self._lock:
                if self.recorder is not None:  # recorded as applied, rejected ones included
                    self.recorder.setpoint(source, value)
                self.twin.set_surface_speed(value)
            return True
        except SetpointError as exc:
            self.get_logger().warning(f'rejected {source}: {exc}; keeping '
                                      f'{self.twin.surface_speed_setpoint:.3f} rad/s')
            return False

    def _on_speed(self, msg):
        if self._apply_speed(msg.data, 'surface_speed_setpoint'):
            self.operator_speed = msg.data
            self.last_command_time = None  # a new operator set-point takes over at once

    def _on_command(self, msg):
        if self._apply_speed(msg.data, 'surface_speed_command'):
            self.last_command_time = time.monotonic()

    def _on_hook_load(self, msg):
        try:
            with self._lock:
                if self.recorder is not None:
                    self.recorder.setpoint('hook_load_setpoint', msg.data)
                self.twin.set_hook_load(msg.data)
        except SetpointError as exc:
            self.get_logger().warning(f'rejected hook_load_setpoint: {exc}; keeping '
                                      f'{self.twin.hook_load_N:.0f} N')

    def _on_parameters(self, params):
        for prm in params:
            if prm.name in _RESTART_ONLY:
                return SetParametersResult(successful=False,
                                           reason=f'{prm.name} only takes effect at start-up')
        for prm in params:
            if prm.name == 'real_time_factor':  # re-anchor so that simulated time is continuous
                self._start_wall = time.monotonic()
                self._start_sim = self.twin.time_s
            if prm.name == 'publish_rate_hz' and not self.fast:
                self._timer.cancel()
                self._timer = self.create_timer(1.0 / prm.value, self._tick)
        return SetParametersResult(successful=True)

    # --- real-time loop ------------------------------------------------------------------
    def _tick(self):
        if self.blow_up:
            return
        timeout = self.get_parameter('command_timeout_s').value
        if self.last_command_time is not None and \
                time.monotonic() - self.last_command_time > timeout:
            self.last_command_time = None
            self.get_logger().warning('controller commands stopped: back to the operator '
                                      'set-point')
            self._apply_speed(self.operator_speed, 'surface_speed_setpoint')
        period = 1.0 / self.get_parameter('publish_rate_hz').value
        if self.fast:
            target = self.twin.time_s + period
        else:
            rtf = self.get_parameter('real_time_factor').value
            if self._start_wall is None:
                self._start_wall = time.monotonic()
            target = self._start_sim + (time.monotonic() - self._start_wall) * rtf
        nominal = max(1, int(period * (1.0 if self.fast else rtf) / self.twin.step_s))
        try:
            with self._lock:
                self.twin.advance_to(target, max_steps=4 * nominal + 4)
                m = self.twin.measurements()
        except Exception as exc:  # noqa: BLE001 - model blow-up: report, keep the node up
            self.blow_up = str(exc)
            self.get_logger().error(f'model stopped: {exc}')
            return
        if target - self.twin.time_s > 2 * self.twin.step_s:
            self.overruns += 1
        self._last_measurements = m
        self._publish(m)

    def _publish(self, m):
        stamp = T.stamp_fields(ns=self.get_clock().now().nanoseconds)
        messages = T.measurement_messages(m, stamp)
        if self.recorder is not None:  # first: whatever a subscriber got is in the file
            self.recorder.measurements(m, messages=messages)
        for topic, fields in messages:
            cls, pub = self.pub[topic.name]
            pub.publish(to_message(cls, fields))
        if self.fast:
            self._send('/clock', T.clock_fields(m['time_s']), m['time_s'])

    # --- stability advisory (off the real-time path) ---------------------------------
    def _advise(self):
        from ..stability.spectrum import critical_speed, spectral_abscissa
        while not self._stop.is_set():
            try:
                with self._lock:
                    groups = self.twin.operating_point()
                model = self.twin.scenario.model
                t_star = self.twin.scales.time_s
                absc = spectral_abscissa(model, groups) / t_star
                wc = critical_speed(model, groups, 0.2, 60.0 * t_star, samples=12, rtol=1e-3)
                self.advisory = (absc, (wc / t_star) if wc is not None else float('nan'))
                self._send('stability/spectral_abscissa', {'data': float(absc)})
                self._send('stability/critical_surface_speed',
                           {'data': float(self.advisory[1])})
            except (ParameterError, ValueError) as exc:  # e.g. WOB below the friction threshold
                self.get_logger().info(f'stability advisory skipped: {exc}')
            self._stop.wait(self.get_parameter('stability_period_s').value)

    def _publish_diagnostics(self):
        health = self.twin.health()
        m = self._last_measurements
        if m is None:
            return  # nothing simulated yet
        if self.blow_up:
            level, message = 2, f'model stopped: {self.blow_up}'
        elif self.overruns or health['history_overflows']:
            level, message = 1, 'overruns or delay overflow'
        else:
            level, message = 0, 'running'
        values = {'simulated_time_s': m['time_s'], 'delay_residual_rad': m['delay_residual_rad'],
                  'overruns': self.overruns, 'rejected_setpoints': health['rejected_setpoints'],
                  'delay_history_overflows': health['history_overflows'],
                  'stick_slip_events': health['events']}
        if self.advisory:
            values['spectral_abscissa_1_s'], values['critical_surface_speed_rad_s'] = \
                self.advisory
        stamp = T.stamp_fields(ns=self.get_clock().now().nanoseconds)
        self._send('/diagnostics', T.diagnostics_fields(stamp, level, message, values))

    def destroy_node(self):
        self._stop.set()
        if self._advisor is not None:
            self._advisor.join(timeout=30.0)
        if self.recorder is not None:
            self.recorder.close()
        return super().destroy_node()


def main(args=None):
    return run_node(TwinNode, 'twin_node', args)


if __name__ == '__main__':
    raise SystemExit(main())
