"""What the bit does, from surface measurements only (docs/estimation.md).

:class:`DownholeEstimator` runs two :class:`~drill_twin.estimation.chain_observer.ChainObserver`
filters on the string model of a configuration — torsion (input: top-drive speed,
measured: surface torque; unknown: torque on bit) and, when hook load and block velocity
are measured, the axial string (input: hook load; measured: block velocity; unknown:
weight on bit) — and adds what follows from the bit/rock interface law without its
parameters:

* **no backward rotation** (§3.3): on bottom the bit cannot turn backwards; the estimate
  is projected on ω_bit ≥ 0 with the filter's covariance ("on bottom": the weight on bit
  is above ``stuck_z`` standard deviations of its estimate, or is not measured; off
  bottom the bit turns freely and is never stuck);
* **uncertainty consistent with the innovations**: each filter's standard deviations
  are scaled by √(mean ν²/S over ``monitor_window_s``), never below 1 — the filter's
  own ones assume a bit torque that moves as a slow random walk, and during stick-slip
  its innovations are 4-18 times their predicted variance (docs §3);
* **stuck**: the bit is at rest at some instant of the sample period that begins now
  (a sampled flag stands for its period, as a published value holds until the next):
  its speed, estimated now or predicted over the period, is indistinguishable from zero
  — below ``stuck_z`` (1.645: one-sided 95 %) standard deviations (a statistical test,
  not a velocity threshold: it scales with what the sensors allow);
* **stick-slip severity**: (max − min)/(2 mean) of the estimated bit speed over the last
  ``severity_window_s`` (the twin's own definition);
* **innovation statistics**: the normalised innovation squared ν²/S of each filter
  averaged over ``monitor_window_s`` (for diagnostics: during stick-slip the bit torque
  jumps at every transition, so even the exact model's mean is 4-18, not the χ² value 1);
  above ``innovation_alarm`` (100) the model does not fit: ``model_mismatch``;
* **model mismatch and self-tuning** (:mod:`.tuning`): the last ``tuning_window_s`` of
  surface speed and torque are kept; :meth:`DownholeEstimator.self_tune` fits the string
  to them, flags a mismatch when the fit is clearly better and its first mode or BHA
  inertia is off by more than the tolerance, and (``apply``) continues on the fitted
  string.

Everything is SI; one update costs two matrix-vector products per axis.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, fields

import numpy as np

from .chain_observer import AxisModel, ChainObserver, axial_axis, torsional_axis
from .tuning import TorsionalFit, fit_torsional

__all__ = ['SensorNoise', 'SurfaceSample', 'Estimate', 'EstimatorTuning',
           'DownholeEstimator', 'estimate_series']


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of the surface measurements (white, per sample).

    The default is the issue's specification on a rig sized for the benchmark string:
    0.5 % of a 300 rpm (31.4 rad/s) speed range, 1 % of a 10 kN·m torque range, 1 % of a
    1 MN hook-load range, 0.5 % of a 1 m/s block-velocity range.
    """

    speed_rad_s: float = 0.005 * 31.4159
    torque_Nm: float = 0.01 * 10.0e3
    hook_load_N: float = 0.01 * 1.0e6
    block_velocity_m_s: float = 0.005 * 1.0

    def __post_init__(self):
        for name in ('speed_rad_s', 'torque_Nm', 'hook_load_N', 'block_velocity_m_s'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'sensor noise {name} must be finite and > 0, got {value!r}')


@dataclass(frozen=True)
class EstimatorTuning:
    """Design parameters of the filters (docs/estimation.md §3).

    ``torque_rate_Nm``: random-walk intensity of the torque on bit [N·m/√s];
    ``wob_rate_N``: of the weight on bit [N/√s]; ``stuck_z``: the stuck test's number of
    standard deviations; ``stuck_resolution_s``: the spacing [s] at which the predicted
    bit speed is tested over each sample period (the stick phases of the twin's runs last
    from 1 ms to 0.15 s); ``severity_window_s`` [s]; ``monitor_window_s`` [s]: the
    window of the innovation statistics (and of the standard deviations' scale);
    ``tuning_window_s``: surface data kept for self-tuning [s];
    ``tuning_torque_rate_Nm``: the bit-torque random walk of the fit's filters (fast, so
    that the stick-slip torque jumps do not bias the string parameters, §5);
    ``mismatch_tolerance``: relative first-mode or BHA-inertia change that is a mismatch;
    ``retune_improvement``: innovation-power reduction for which a confirmed fit replaces
    the model; ``innovation_alarm``: the torsional filter's normalised innovation squared,
    averaged over ``monitor_window_s``, above which the model is reported not to fit (the
    exact model stays below 18 on every truth of the study, at 100 and 10 Hz; a pipe 10 %
    off gives > 5000, a BHA 50 % off > 500, a twin run 5× faster than the estimator's
    clock 8000).
    """

    torque_rate_Nm: float = 10.0
    wob_rate_N: float = 2000.0
    stuck_z: float = 1.645
    stuck_resolution_s: float = 1e-3
    severity_window_s: float = 10.0
    monitor_window_s: float = 10.0
    tuning_window_s: float = 60.0
    tuning_torque_rate_Nm: float = 3000.0
    mismatch_tolerance: float = 0.2
    retune_improvement: float = 0.25
    innovation_alarm: float = 100.0


@dataclass(frozen=True)
class SurfaceSample:
    """One sample of the rig's surface measurements (SI); the axial pair may be NaN."""

    surface_speed_rad_s: float
    surface_torque_Nm: float
    hook_load_N: float = math.nan
    block_velocity_m_s: float = math.nan


@dataclass(frozen=True)
class Estimate:
    """The estimator's output after one sample (SI; ``*_std``: posterior standard
    deviations; ``nis_*``: windowed mean normalised innovation squared)."""

    time_s: float
    bit_speed_rad_s: float
    bit_speed_std: float
    stuck: bool
    torque_on_bit_Nm: float
    torque_on_bit_std: float
    weight_on_bit_N: float
    weight_on_bit_std: float
    bit_axial_speed_m_s: float
    bit_axial_speed_std: float
    stick_slip_severity: float
    nis_torsional: float
    nis_axial: float
    model_mismatch: bool


@dataclass
class _Monitor:
    """Windowed mean of the normalised innovation squared, and its alarm bound."""

    size: int
    values: deque = field(default_factory=deque)
    total: float = 0.0

    @property
    def full(self) -> bool:
        return len(self.values) >= self.size

    def add(self, nis: float) -> float:
        self.values.append(nis)
        self.total += nis
        if len(self.values) > self.size:
            self.total -= self.values.popleft()
        return self.mean

    @property
    def mean(self) -> float:
        """The window's mean (NaN before the first value)."""
        return self.total / len(self.values) if self.values else math.nan

    @property
    def std_scale(self) -> float:
        """√(mean ν²/S), at least 1: what the filter's standard deviations are
        multiplied by for them to agree with the innovations (docs §3)."""
        mean = self.mean
        return math.sqrt(mean) if mean > 1.0 else 1.0


class _RunningRange:
    """Minimum, maximum and mean of the last ``size`` values in O(1) per value
    (monotonic deques of (index, value); the mean from a running sum re-summed every
    ``size`` values against round-off)."""

    def __init__(self, size: int):
        self.size = size
        self.values = deque()
        self.low, self.high = deque(), deque()
        self.total = 0.0
        self.count = 0

    def add(self, value: float) -> tuple[float, float, float]:
        i = self.count
        self.count += 1
        self.values.append(value)
        self.total += value
        if len(self.values) > self.size:
            self.total -= self.values.popleft()
        if self.count % self.size == 0:
            self.total = sum(self.values)
        for q, worse in ((self.low, lambda a, b: a >= b), (self.high, lambda a, b: a <= b)):
            while q and worse(q[-1][1], value):
                q.pop()
            q.append((i, value))
            if q[0][0] <= i - self.size:
                q.popleft()
        return self.low[0][1], self.high[0][1], self.total / len(self.values)


class DownholeEstimator:
    """Downhole estimates of a string given by a scenario (its finite-element model).

    Parameters
    ----------
    scenario : Scenario
        An SI finite-element configuration: the estimator's model of the string.
    rate_hz : float
        Sample rate of the surface measurements [Hz] (10-1000).
    noise : SensorNoise
    tuning : EstimatorTuning
    torsional, axial : AxisModel, optional
        Replace the scenario's axes (a deliberately wrong or a re-tuned model).
    """

    def __init__(self, scenario, rate_hz: float = 100.0, noise: SensorNoise = SensorNoise(),
                 tuning: EstimatorTuning = EstimatorTuning(),
                 torsional: AxisModel | None = None, axial: AxisModel | None = None):
        if not (math.isfinite(rate_hz) and 1.0 <= rate_hz <= 10000.0):
            raise ValueError(f'rate_hz {rate_hz!r} outside [1, 10000] Hz')
        if scenario.model.torsional is None or scenario.model.element_lengths_m is None:
            raise ValueError('the estimator needs a finite-element string (model.type: fem)')
        self.scenario = scenario
        self.rate_hz = float(rate_hz)
        self.noise, self.tuning = noise, tuning
        self.weight_N = scenario.system.buoyed_weight_N()
        self.torsional_model = torsional or torsional_axis(scenario)   # as configured
        self.torsion: ChainObserver | None = None
        self._use_torsion(self.torsional_model)
        keep = max(1, round(tuning.tuning_window_s * rate_hz))
        self._history = (deque(maxlen=keep), deque(maxlen=keep))
        self.last_fit: TorsionalFit | None = None
        self.fits: list[tuple[float, TorsionalFit]] = []   # (time_s, fit) of self_tune
        self.model_mismatch = False      # a confirmed fit far from the model (§5)
        self.innovation_alarm = False    # innovations far beyond their predicted size
        self.axial = None
        if scenario.raw['model'].get('axial_top', 'hook_load') != 'velocity':
            self.axial = ChainObserver(axial or axial_axis(scenario, self.weight_N),
                                       1.0 / rate_hz, noise.hook_load_N,
                                       noise.block_velocity_m_s, tuning.wob_rate_N)
        window = max(1, round(tuning.monitor_window_s * rate_hz))
        self._nis = {'torsional': _Monitor(window), 'axial': _Monitor(window)}
        self._speeds = _RunningRange(max(1, round(tuning.severity_window_s * rate_hz)))
        self._on_bottom = True
        self.time_s = 0.0
        self.started = False

    def _use_torsion(self, axis: AxisModel):
        """Estimate on the torsional string ``axis`` (the configured one, or a fit's),
        continuing from the current filter's state if there is one."""
        previous = self.torsion
        self.active_model = axis
        self.torsion = ChainObserver(axis, 1.0 / self.rate_hz, self.noise.speed_rad_s,
                                     self.noise.torque_Nm, self.tuning.torque_rate_Nm)
        if previous is not None:
            self.torsion.continue_from(previous)
        steps = max(1, math.ceil(1.0 / (self.rate_hz * self.tuning.stuck_resolution_s)
                                 - 1e-9))
        self._speed_ahead = self.torsion.lookahead(self.torsion.bit_velocity, steps)

    # --- start -----------------------------------------------------------------------
    def start(self, sample: SurfaceSample):
        """Initialise in steady drilling at the sample: turning at the surface speed with
        the surface torque on the bit (no twist rate) and, axially, the weight on bit that
        balances the hook load."""
        self.torsion.start(sample.surface_speed_rad_s, sample.surface_torque_Nm)
        if self.axial is not None and math.isfinite(sample.hook_load_N):
            self.axial.start(-sample.hook_load_N, self.weight_N - sample.hook_load_N)
        self.started = True

    # --- one sample ---------------------------------------------------------------------
    def update(self, sample: SurfaceSample) -> Estimate:
        """Fold in one sample (taken one period after the previous one).

        Raises
        ------
        ValueError
            If the top-drive speed or the surface torque is not finite: a corrupt sample
            would stay in the filter's state (:class:`~.surface_gate.SurfaceGate` holds the
            last acceptable value instead).
        """
        if not (math.isfinite(sample.surface_speed_rad_s)
                and math.isfinite(sample.surface_torque_Nm)):
            raise ValueError(f'surface speed and torque must be finite, got {sample}')
        if not self.started:
            self.start(sample)
        self.time_s += 1.0 / self.rate_hz
        tors = self.torsion
        nu = tors.update(sample.surface_speed_rad_s, sample.surface_torque_Nm)
        self._history[0].append(sample.surface_speed_rad_s)
        self._history[1].append(sample.surface_torque_Nm)
        nis_t = self._nis['torsional'].add(nu * nu / tors.innovation_var)
        self.innovation_alarm = (self._nis['torsional'].full
                                 and nis_t > self.tuning.innovation_alarm)
        wob, wob_std, rop, rop_std, nis_a = self._update_axial(sample)
        z = self.tuning.stuck_z
        on_bottom = not (wob <= z * wob_std)   # weight on bit evidently > 0, or unknown
        self._on_bottom = on_bottom
        if on_bottom:                          # the bit does not turn backwards
            tors.clamp_below(tors.bit_velocity, 0.0)
        speed = float(tors.x[tors.bit_velocity])
        scale = self._nis['torsional'].std_scale      # the innovations' consistency (§3)
        speed_std = scale * tors.std(tors.bit_velocity)
        stuck = on_bottom and (speed < z * speed_std or self._speed_ahead.lowest(
            tors.x, sample.surface_speed_rad_s, z * scale) < 0.0)
        low, high, mean = self._speeds.add(speed)
        severity = (high - low) / (2 * mean) if mean > 0 else 0.0
        return Estimate(time_s=self.time_s, bit_speed_rad_s=speed, bit_speed_std=speed_std,
                        stuck=stuck,
                        torque_on_bit_Nm=float(tors.x[tors.bit_force]),
                        torque_on_bit_std=scale * tors.std(tors.bit_force),
                        weight_on_bit_N=float(wob), weight_on_bit_std=float(wob_std),
                        bit_axial_speed_m_s=float(rop), bit_axial_speed_std=float(rop_std),
                        stick_slip_severity=float(severity),
                        nis_torsional=float(nis_t), nis_axial=float(nis_a),
                        model_mismatch=self.model_mismatch or self.innovation_alarm)

    def _update_axial(self, sample: SurfaceSample) -> tuple[float, ...]:
        """Weight on bit [N], its std, the bit's axial speed [m/s], its std (scaled by the
        axial innovations' consistency, §3) and the windowed axial NIS — NaN without an
        axial filter; predicted only when the sample lacks hook load or block velocity."""
        ax = self.axial
        if ax is None:
            return (math.nan,) * 5
        nis = math.nan
        if math.isfinite(sample.hook_load_N) and math.isfinite(sample.block_velocity_m_s):
            nu = ax.update(-sample.hook_load_N, sample.block_velocity_m_s)
            nis = self._nis['axial'].add(nu * nu / ax.innovation_var)
        else:
            ax.predict()
        scale = self._nis['axial'].std_scale
        return (float(ax.x[ax.bit_force]), scale * ax.std(ax.bit_force),
                float(ax.x[ax.bit_velocity]), scale * ax.std(ax.bit_velocity), nis)

    def skip(self, periods: int = 1):
        """Advance ``periods`` sample periods without a measurement (samples that were not
        taken: a sampler that fell behind its clock).  The filters predict with the inputs
        held; the posterior covariance stays the steady one (a lower bound over the gap);
        the self-tuning window takes the held values, the severity the predicted speed."""
        tors = self.torsion
        for _ in range(max(0, int(periods))):
            self.time_s += 1.0 / self.rate_hz
            tors.predict()
            if self.axial is not None:
                self.axial.predict()
            if self._on_bottom:
                tors.clamp_below(tors.bit_velocity, 0.0)
            if self._history[0]:
                for kept in self._history:
                    kept.append(kept[-1])
            self._speeds.add(float(tors.x[tors.bit_velocity]))

    def run(self, samples, tune_every_s: float | None = None,
            retune: bool = True, progress=None) -> list[Estimate]:
        """Every sample of a sequence, in order; with ``tune_every_s`` [s], self-tune
        that often once the tuning window is full (the fits go to :attr:`fits`).
        ``progress(fraction, detail)`` every 1 % of the samples and after each fit."""
        every = max(1, round(tune_every_s * self.rate_hz)) if tune_every_s else 0
        first = round(self.tuning.tuning_window_s * self.rate_hz)
        total = len(samples)
        report = max(1, total // 100)
        out = []
        for i, sample in enumerate(samples, start=1):
            out.append(self.update(sample))
            fitted = every and i >= first and (i - first) % every == 0
            if fitted:
                self.self_tune(retune)
            if progress is not None and (fitted or i % report == 0 or i == total):
                progress(i / total, f'{i}/{total} samples, {len(self.fits)} fits')
        return out

    # --- self-tuning --------------------------------------------------------------------
    def tuning_data(self) -> tuple[np.ndarray, np.ndarray]:
        """The kept surface speed [rad/s] and torque [N·m] samples (oldest first)."""
        return np.array(self._history[0]), np.array(self._history[1])

    def fit(self, speed=None, torque=None) -> TorsionalFit:
        """Fit the torsional string to the kept samples (or to ``speed``/``torque``),
        relative to the configured model; pure (changes nothing)."""
        if speed is None:
            speed, torque = self.tuning_data()
        return fit_torsional(self.torsional_model, speed, torque, self.rate_hz,
                             self.noise.speed_rad_s, self.noise.torque_Nm,
                             self.tuning.tuning_torque_rate_Nm,
                             tolerance=self.tuning.mismatch_tolerance)

    def apply_fit(self, fit: TorsionalFit, retune: bool = True):
        """Take a fit.  A fit is *confirmed* when the previous one identified the same
        string (BHA inertia and first-mode frequency within half the mismatch tolerance):
        one stretch of weakly excited data (the growth phase before stick-slip, steady
        drilling) can mislead a fit, two agreeing stretches rarely do.  A confirmed fit
        sets ``model_mismatch`` (the configured model does not fit) and, with ``retune``,
        when the fit removes at least ``retune_improvement`` of the model's innovation
        power (the exact model's own fits gain 5-15 %: their few-% bias in BHA inertia
        would only cost accuracy), the estimator continues on the fitted string; the
        state (deformations, velocities, bit torque) carries over — the fitted chain has
        the same elements.  A fit of data without excitation (``fit.identifiable`` False)
        says nothing about the string: it changes nothing."""
        if not fit.identifiable:
            return
        previous, self.last_fit = self.last_fit, fit
        if previous is None or not _same_string(previous, fit,
                                                self.tuning.mismatch_tolerance / 2):
            return
        self.model_mismatch = fit.mismatch and previous.mismatch
        if retune and fit.improvement >= self.tuning.retune_improvement:
            self._use_torsion(fit.axis(self.torsional_model))

    def self_tune(self, retune: bool = True) -> TorsionalFit:
        """:meth:`fit` on the kept samples, then :meth:`apply_fit`."""
        fit = self.fit()
        self.apply_fit(fit, retune)
        self.fits.append((self.time_s, fit))
        return fit


def _same_string(a: TorsionalFit, b: TorsionalFit, tolerance: float) -> bool:
    """Two fits identify the same string: BHA inertia and first-mode frequency agree to
    ``tolerance`` (relative)."""
    return (abs(a.bha_inertia_scale / b.bha_inertia_scale - 1.0) <= tolerance and
            abs(a.fitted_mode.frequency_hz / b.fitted_mode.frequency_hz - 1.0) <= tolerance)


def estimate_series(estimates) -> dict:
    """The fields of a sequence of :class:`Estimate` as arrays, one per field."""
    return {f.name: np.array([getattr(e, f.name) for e in estimates])
            for f in fields(Estimate)}
