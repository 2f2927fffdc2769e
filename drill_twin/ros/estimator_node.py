"""``downhole_estimator``: what the bit does, from surface topics only (adapter over
:class:`drill_twin.estimation.DownholeEstimator`, docs/estimation.md).

Inputs (``std_msgs/Float64``, SI, sensor-data QoS; remap a rig's topics onto them):
``surface/top_drive_speed`` [rad/s], ``surface/torque`` [N·m] and, for the weight on
bit, ``surface/hook_load`` [N] and ``surface/block_velocity`` [m/s].  A timer at
``rate_hz`` on the node clock (``/clock`` under ``use_sim_time``) samples the latest value
of each (zero-order hold) and updates the filters.  Outputs: ``estimate/bit/velocity``
(``TwistWithCovarianceStamped``: angular.x the bit speed with its variance at
covariance[21], linear.x the bit's axial speed with its variance at covariance[0]),
``estimate/bit/wrench`` (force.x weight on bit, torque.x torque on bit),
``estimate/bit/stuck`` (the bit at rest at some instant of the sample period that
begins: the flag holds until the next sample), ``estimate/stick_slip_severity`` and
``/diagnostics`` (innovation statistics, the last self-tuning fit, the model-mismatch
warning).

Self-tuning (``self_tuning_period_s`` > 0) fits the string to the last
``tuning_window_s`` of data in a worker thread (the filter loop is compiled ``nogil``),
so the sampling timer keeps its rate; the result is taken on the executor's thread.
"""
from __future__ import annotations

import dataclasses
import time
from concurrent.futures import ThreadPoolExecutor

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64

from ..config.scenario import load_scenario
from ..errors import ParameterError
from ..estimation.estimator import DownholeEstimator, EstimatorTuning, SensorNoise
from ..estimation.surface_gate import CHANNELS, SurfaceGate, SurfaceLimits
from ..runtime.arbitration import Watchdog
from ..runtime.pacing import SamplePacing
from ..runtime.settings import ESTIMATOR_SETTINGS
from ..topics import ESTIMATE_TOPICS, SURFACE_INPUTS, diagnostics_fields, stamp_fields
from .common import declare_settings, run_node, warn_unknown_overrides
from .entry import interruptible
from .messages import message_class, qos_profile, to_message

__all__ = ['EstimatorNode', 'main']

#: diagnostics warn of refused samples for this long after the last one [s]
_REJECTION_MEMORY_S = 10.0
#: longest gap [s] the filter is predicted over sample by sample (after a longer one the
#: prediction adds nothing but time)
_MAX_SKIP_S = 10.0


class EstimatorNode(Node):
    """The downhole estimator node (see module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('downhole_estimator', **kwargs)
        declare_settings(self, ESTIMATOR_SETTINGS)
        warn_unknown_overrides(self)
        g = self._param
        overrides = [o for o in g('overrides') if o]
        with interruptible():
            scenario = load_scenario(g('config'), overrides)
            if not scenario.is_si:
                raise ParameterError('downhole_estimator needs an SI configuration (units: si)')
            noise = SensorNoise(g('speed_noise_rad_s'), g('torque_noise_Nm'),
                                g('hook_load_noise_N'), g('block_velocity_noise_m_s'))
            tuning = dataclasses.replace(EstimatorTuning(), torque_rate_Nm=g('torque_rate_Nm'),
                                         tuning_window_s=g('tuning_window_s'))
            self.est = DownholeEstimator(scenario, g('rate_hz'), noise, tuning)
        self.gate = SurfaceGate(SurfaceLimits(
            g('max_surface_speed_rad_s'), g('max_surface_torque_Nm'), g('max_hook_load_N'),
            g('max_block_speed_m_s')))
        self.last_rejection = None          # (monotonic time [s], reason)
        self.watch = Watchdog(g('measurement_timeout_s'))
        for name, channel in zip(SURFACE_INPUTS, CHANNELS):
            self.create_subscription(Float64, name, self._on_input(name, channel),
                                     qos_profile_sensor_data)
        # (publisher, message class, topic) per estimate topic, built once
        self.pubs = [(self.create_publisher(message_class(t.type), t.name, qos_profile(t.qos)),
                      message_class(t.type), t) for t in ESTIMATE_TOPICS]
        self.diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.estimate = None
        self.samples = 0
        self.pacing = SamplePacing(g('rate_hz'))
        self.fits = 0
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix='self_tuning')
        self._fit_future = None
        self._next_fit_s = None
        self.create_timer(1.0 / g('rate_hz'), self._sample)
        self.create_timer(1.0, self._diagnostics)
        self.add_post_set_parameters_callback(self._apply_parameters)   # ranges: descriptors
        self.get_logger().info(
            f'estimating at {g("rate_hz"):g} Hz from {", ".join(SURFACE_INPUTS)}; '
            f'first torsional mode of the model {self._mode_hz():.4f} Hz')

    def _param(self, name):
        return self.get_parameter(name).value

    def _mode_hz(self) -> float:
        from ..estimation.tuning import first_mode
        return first_mode(self.est.active_model).frequency_hz

    def _on_input(self, name, channel):
        def callback(msg):
            why = self.gate.offer(channel, msg.data)
            if why is not None:             # refused: the last acceptable value is held
                self.last_rejection = (time.monotonic(), f'{name}: {why}')
                self.get_logger().warning(f'rejected {name} sample: {why}; holding the last '
                                          'acceptable value', throttle_duration_sec=1.0)
            elif channel == 'surface_torque_Nm':
                self.watch.feed(time.monotonic())
        return callback

    # --- parameters: the descriptors validate, applied after ------------------------------
    def _apply_parameters(self, params):
        for prm in params:
            if prm.name == 'measurement_timeout_s':
                self.watch.timeout_s = float(prm.value)

    # --- sampling ---------------------------------------------------------------------------
    def _sample(self):
        sample = self.gate.sample()
        if sample is None or self.watch.expired(time.monotonic()) or self.watch.silent:
            self.pacing.restart()
            return                      # nothing to estimate from (diagnostics say so)
        periods = self.pacing.periods(self.get_clock().now().nanoseconds, time.monotonic())
        if periods == 0:
            return                      # the clock did not advance a period (or went back)
        if self.est.started:            # the periods whose samples were not taken
            self.est.skip(min(periods - 1, round(_MAX_SKIP_S * self.est.rate_hz)))
        self.estimate = self.est.update(sample)
        self.samples += 1
        stamp = self.get_clock().now().to_msg()
        fields = dataclasses.asdict(self.estimate)
        st = stamp_fields(ns=stamp.sec * 1_000_000_000 + stamp.nanosec)
        for pub, cls, topic in self.pubs:
            pub.publish(to_message(cls, topic.fields(fields, st)))
        self._self_tune()

    def _self_tune(self):
        period = self._param('self_tuning_period_s')
        if self._fit_future is not None and self._fit_future.done():
            try:
                fit = self._fit_future.result()
            except (ValueError, ArithmeticError) as exc:
                self.get_logger().warning(f'self-tuning failed: {exc}')
            else:
                self.est.apply_fit(fit, retune=self._param('self_tuning_apply'))
                self.fits += 1
                self.get_logger().info(_fit_summary(fit))
            self._fit_future = None
        if period <= 0 or self._fit_future is not None:
            return
        full = self.samples >= self.est.tuning.tuning_window_s * self.est.rate_hz
        now = self.est.time_s
        if full and (self._next_fit_s is None or now >= self._next_fit_s):
            self._next_fit_s = now + period
            speed, torque = self.est.tuning_data()
            self._fit_future = self._pool.submit(self.est.fit, speed, torque)

    def _diagnostics(self):
        e = self.estimate
        values = {'samples': self.samples, 'self_tuning_fits': self.fits,
                  'rejected_samples': self.gate.rejected_total,
                  'skipped_periods': self.pacing.skipped}
        if e is not None:
            values.update(nis_torsional=f'{e.nis_torsional:.3g}',
                          nis_axial=f'{e.nis_axial:.3g}',
                          bit_speed_std_rad_s=f'{e.bit_speed_std:.3g}',
                          torque_on_bit_std_Nm=f'{e.torque_on_bit_std:.3g}',
                          weight_on_bit_std_N=f'{e.weight_on_bit_std:.3g}')
        fit = self.est.last_fit
        if fit is not None:
            values.update(model_first_mode_hz=f'{fit.model_mode.frequency_hz:.5g}',
                          fitted_first_mode_hz=f'{fit.fitted_mode.frequency_hz:.5g}',
                          fitted_first_mode_damping=f'{fit.fitted_mode.damping_ratio:.3g}',
                          fitted_bha_inertia_scale=f'{fit.bha_inertia_scale:.4g}',
                          fitted_pipe_stiffness_scale=f'{fit.pipe_stiffness_scale:.4g}',
                          innovation_power_reduction=f'{fit.improvement:.3g}')
        warnings = self._warnings(time.monotonic())
        level, message = (1, '; '.join(warnings)) if warnings else (0, 'estimating')
        stamp = stamp_fields(ns=self.get_clock().now().nanoseconds)
        self.diag_pub.publish(to_message(DiagnosticArray, diagnostics_fields(
            stamp, level, message, values, name='drill_twin: downhole_estimator')))

    def _warnings(self, now_s):
        """Every condition to warn about now, most severe first: one WARN never hides
        another (a corrupt sample while the estimator is behind the clock is both)."""
        found = []
        if self.watch.silent:
            found.append('surface torque stopped: estimates held' if
                         self.watch.last_s is not None else
                         'waiting for surface/top_drive_speed and surface/torque')
        if self.pacing.recently_behind(now_s):
            found.append('falling behind the clock: sample periods predicted without '
                         'a measurement (see skipped_periods)')
        if self.last_rejection is not None and \
                now_s - self.last_rejection[0] < _REJECTION_MEMORY_S:
            found.append(f'rejecting corrupt surface samples ({self.last_rejection[1]})')
        if self.est.model_mismatch:
            found.append('model mismatch: the string model does not fit the surface '
                         'data (see fitted_* values)')
        elif self.est.innovation_alarm:
            found.append('model mismatch: the surface torque is far from what the '
                         'string model predicts (nis_torsional; is the string, the '
                         'sensor noise or the time base what is configured?)')
        return found

    def destroy_node(self):
        self._pool.shutdown(wait=False, cancel_futures=True)
        return super().destroy_node()


def _fit_summary(fit) -> str:
    """One log line for a self-tuning fit."""
    if not fit.identifiable:
        return ('self-tuning: no excitation (the surface torque varies within its sensor '
                f'noise, SNR {fit.torque_snr:.2g}), model kept')
    return (f'self-tuning: first mode {fit.fitted_mode.frequency_hz:.4f} Hz '
            f'(model {fit.model_mode.frequency_hz:.4f}), damping '
            f'{fit.fitted_mode.damping_ratio:.2e}, BHA inertia x{fit.bha_inertia_scale:.3f}, '
            f'pipe stiffness x{fit.pipe_stiffness_scale:.3f}, innovation power '
            f'-{100 * fit.improvement:.0f} %' + ('; MODEL MISMATCH' if fit.mismatch else ''))


def main(args=None):
    return run_node(EstimatorNode, 'downhole_estimator', args)


if __name__ == '__main__':
    raise SystemExit(main())
