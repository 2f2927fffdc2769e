"""Self-tuning of the torsional string from surface data, and the model-mismatch test
(docs/estimation.md §5).

A prediction-error fit: among strings that differ from the estimator's model by a BHA
inertia scale ``a``, a torsional stiffness scale ``b`` of the pipe (the elements above
the BHA) and an added stiffness-proportional damping ``θ_add`` [s], find the one whose
steady-state Kalman filter predicts the measured surface torque best from the measured
top speed (least mean squared one-step innovation; the bit torque stays an unknown
random walk, so the fit never needs the bit law). The identified string's first
torsional mode (clamped at the top drive, free at the bit: ``det(K − ω² M) = 0``,
Rayleigh damping ratio ``ζ = η/(2ω) + θω/2``) is what a driller reads as "the string's
frequency and damping".

The fit needs excitation: its information is the surface torque's fluctuation beyond the
sensor noise.  Where that fluctuation is below the noise (steady drilling), the
fluctuations of the *measured* speed are mostly sensor noise, which the filter takes as
the string's input: the best predictor is then a string that hardly responds to its
input (an errors-in-variables bias; measured: BHA inertia ×4 and stiffness ×1/4, the
bounds, "improving" the prediction by 27-50 %).  Data whose torque variance exceeds the
noise variance by less than :data:`MIN_TORQUE_SNR` times the noise variance are not
fitted (``TorsionalFit.identifiable`` False).

The mismatch test compares models, not absolute χ² levels (the bit torque jumps at
every stick-slip transition make the innovations heavy-tailed, so the χ² level of even
the exact model is not 1): the model no longer fits when the best fit explains the
surface torque clearly better (``improvement`` ≥ ``min_improvement``) *and* its first
mode or BHA inertia is outside ``tolerance`` of the model's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from scipy.linalg import eigh
from scipy.optimize import minimize

from .chain_observer import AxisModel, ChainObserver

__all__ = ['MIN_TORQUE_SNR', 'FirstMode', 'TorsionalFit', 'first_mode', 'innovation_power',
           'fit_torsional']

#: least signal-to-noise ratio of the surface torque (variance beyond the sensor noise over
#: the noise variance) for a window to be fitted: the string's response at least as large
#: as the noise (measured: steady drilling −0.07…0.38, developed stick-slip 10³–10⁴)
MIN_TORQUE_SNR = 1.0
#: pipe-stiffness scales tried before the local search, every 0.5 % over ±25 %: near the
#: Nyquist frequency the prediction error is sharply multimodal in the pipe's stiffness
#: (it sets the torsional wave's travel time, hence the phase of the stick-slip
#: oscillation at the samples; measured at 10 Hz: 6-13× the least power 0.5 % off,
#: local minima at 18-260× elsewhere), and a simplex started 10 % away stops in one
PIPE_GRID = np.exp(np.arange(-math.log(1.25), math.log(1.25) + 1e-9, 0.005))


@dataclass(frozen=True)
class FirstMode:
    """First torsional mode of a top-clamped string: frequency [Hz], damping ratio [-]."""

    frequency_hz: float
    damping_ratio: float


@dataclass(frozen=True)
class TorsionalFit:
    """Result of :func:`fit_torsional`.

    ``bha_inertia_scale``, ``pipe_stiffness_scale``, ``damping_add_s``: the identified
    string relative to the model; ``model_mode`` / ``fitted_mode``: first modes;
    ``power_model``, ``power_fit``: mean squared innovation of the surface torque
    [N²·m²] of the model and of the fit; ``improvement = 1 − power_fit/power_model``;
    ``mismatch``: the test of the module docstring; ``duration_s``: data used;
    ``evaluations``: filters run; ``torque_snr``: variance of the measured surface torque
    beyond the sensor noise, over the noise's; ``identifiable``: ``torque_snr ≥
    MIN_TORQUE_SNR`` (else
    nothing was fitted and the fit is the model).
    """

    bha_inertia_scale: float
    pipe_stiffness_scale: float
    damping_add_s: float
    model_mode: FirstMode
    fitted_mode: FirstMode
    power_model: float
    power_fit: float
    improvement: float
    mismatch: bool
    duration_s: float
    evaluations: int
    torque_snr: float
    identifiable: bool

    def axis(self, model: AxisModel) -> AxisModel:
        """The identified string (``model`` re-scaled)."""
        return model.scaled(bha_mass=self.bha_inertia_scale,
                            pipe_stiffness=self.pipe_stiffness_scale,
                            theta_add_s=self.damping_add_s)

    def as_dict(self) -> dict:
        out = {k: getattr(self, k) for k in ('bha_inertia_scale', 'pipe_stiffness_scale',
                                             'damping_add_s', 'power_model', 'power_fit',
                                             'improvement', 'mismatch', 'duration_s',
                                             'evaluations', 'torque_snr', 'identifiable')}
        out['model_first_mode_hz'] = self.model_mode.frequency_hz
        out['model_first_mode_damping'] = self.model_mode.damping_ratio
        out['fitted_first_mode_hz'] = self.fitted_mode.frequency_hz
        out['fitted_first_mode_damping'] = self.fitted_mode.damping_ratio
        return out


def first_mode(axis: AxisModel) -> FirstMode:
    """Lowest mode of ``K φ = ω² M φ`` (the top clamped) and its Rayleigh damping ratio."""
    M, _, K, _, _ = axis.matrices()
    omega = math.sqrt(max(float(eigh(K, M, eigvals_only=True, subset_by_index=[0, 0])[0]),
                          0.0))
    zeta = axis.eta / (2.0 * omega) + axis.theta * omega / 2.0 if omega > 0 else math.inf
    return FirstMode(omega / (2.0 * math.pi), zeta)


def innovation_power(axis: AxisModel, speed: np.ndarray, torque: np.ndarray, rate_hz: float,
                     speed_std: float, torque_std: float, torque_rate: float,
                     skip_s: float = 5.0) -> float:
    """Mean squared one-step innovation [N²·m²] of the surface torque of ``axis``'s
    steady-state filter over the samples (``speed`` [rad/s], ``torque`` [N·m] at
    ``rate_hz``), after ``skip_s`` of start-up transient."""
    obs = ChainObserver(axis, 1.0 / rate_hz, speed_std, torque_std, torque_rate)
    obs.start(speed[0], torque[0])
    vectors = np.column_stack([obs.G[:, 0], obs.G[:, 1], obs.gain, obs.cross_gain])
    samples = np.vstack([speed, torque])
    return _mean_squared_innovation(obs.F, vectors, obs.H, obs.D, obs.x.copy(), samples,
                                    int(skip_s * rate_hz))


#: columns of the filter's vectors passed to :func:`_mean_squared_innovation`: the input
#: columns of G (speed, constant), the steady gain and the cross-covariance gain
INPUT_SPEED, INPUT_CONST, GAIN, CROSS_GAIN = range(4)
#: rows of its samples: measured top speed [rad/s], surface torque [N m]
SPEED, TORQUE = range(2)


@numba.njit(cache=False, nogil=True)
def _mean_squared_innovation(F, vectors, H, D, x, samples, skip):
    """The steady-state filter's recursion (``ChainObserver.update``) over the samples;
    mean of the squared innovations from sample ``skip`` on."""
    g_speed, g_const = vectors[:, INPUT_SPEED].copy(), vectors[:, INPUT_CONST].copy()
    gain, cross_gain = vectors[:, GAIN].copy(), vectors[:, CROSS_GAIN].copy()
    speed, torque = samples[SPEED], samples[TORQUE]
    total, count = 0.0, 0
    nu = 0.0
    for i in range(1, speed.size):
        x = F @ x + g_speed * speed[i - 1] + g_const + cross_gain * nu
        nu = torque[i] - (H @ x + D * speed[i])
        x = x + gain * nu
        if i >= skip:
            total += nu * nu
            count += 1
    return total / max(count, 1)


def fit_torsional(model: AxisModel, speed: np.ndarray, torque: np.ndarray, rate_hz: float,
                  speed_std: float, torque_std: float, torque_rate: float,
                  tolerance: float = 0.2, min_improvement: float = 0.05,
                  max_evaluations: int = 80) -> TorsionalFit:
    """Identify the torsional string from surface speed and torque samples.

    Parameters
    ----------
    model : AxisModel
        The estimator's torsional model (:func:`~.chain_observer.torsional_axis`).
    speed, torque : ndarray
        Measured top speed [rad/s] and surface torque [N·m], one sample every
        ``1/rate_hz`` s (at least 20 s).
    speed_std, torque_std, torque_rate
        The filter's noise model (see :class:`~.chain_observer.ChainObserver`).
    tolerance : float
        Relative change of the first-mode frequency or BHA inertia that counts as a
        mismatch.
    min_improvement : float
        Relative reduction of the innovation power that counts as a better fit.
    max_evaluations : int
        Filter runs of each of the two simplex searches (after the model's and the
        :data:`PIPE_GRID` runs).
    """
    speed = np.asarray(speed, float)
    torque = np.asarray(torque, float)
    if speed.shape != torque.shape or speed.size < 20 * rate_hz:
        raise ValueError('the fit needs at least 20 s of paired speed and torque samples')
    if not (np.all(np.isfinite(speed)) and np.all(np.isfinite(torque))):
        raise ValueError('the fit needs finite samples')
    theta_scale = max(model.theta, 1e-4)      # [s]: the fit's added damping per e-fold
    evaluations = 0

    def axis_of(p):
        return model.scaled(bha_mass=math.exp(p[0]), pipe_stiffness=math.exp(p[1]),
                            theta_add_s=max(theta_scale * (math.exp(p[2]) - 1.0),
                                            -model.theta))

    def cost(p):
        nonlocal evaluations
        evaluations += 1
        if np.any(np.abs(p) > math.log(4.0)):
            return math.inf
        try:
            power = innovation_power(axis_of(p), speed, torque, rate_hz, speed_std,
                                     torque_std, torque_rate)
        except (ArithmeticError, np.linalg.LinAlgError):
            return math.inf
        return math.log(power)

    p0 = np.zeros(3)
    base = cost(p0)
    snr = float(np.var(torque)) / torque_std ** 2 - 1.0
    p, best = p0, base
    if snr >= MIN_TORQUE_SNR:       # else: no excitation, the model stands (docstring)
        # the pipe's stiffness on its grid, then a simplex from the best scale found (its
        # step in the pipe's stiffness within the grid's basin) and one from the model
        # (a BHA far off can move the grid's best)
        grid = [cost(np.array([0.0, math.log(b), 0.0])) for b in PIPE_GRID]
        best_pipe = np.array([0.0, math.log(PIPE_GRID[int(np.argmin(grid))]), 0.0])
        for start, step in ((best_pipe, [0.25, 0.01, 0.25]), (p0, [0.25, 0.25, 0.25])):
            result = minimize(cost, start, method='Nelder-Mead',
                              options={'maxfev': max_evaluations, 'xatol': 1e-3,
                                       'fatol': 1e-4, 'initial_simplex': start + np.vstack(
                                           [np.zeros(3), np.diag(step)])})
            if result.fun < best:
                p, best = result.x, result.fun
    fitted = axis_of(p)
    power_model, power_fit = math.exp(base), math.exp(best)
    improvement = 1.0 - power_fit / power_model
    mode0, mode1 = first_mode(model), first_mode(fitted)
    off = max(abs(mode1.frequency_hz / mode0.frequency_hz - 1.0), abs(math.exp(p[0]) - 1.0))
    return TorsionalFit(bha_inertia_scale=math.exp(p[0]), pipe_stiffness_scale=math.exp(p[1]),
                        damping_add_s=fitted.theta - model.theta,
                        model_mode=mode0, fitted_mode=mode1, power_model=power_model,
                        power_fit=power_fit, improvement=improvement,
                        mismatch=bool(improvement >= min_improvement and off > tolerance),
                        torque_snr=snr, identifiable=snr >= MIN_TORQUE_SNR,
                        duration_s=speed.size / rate_hz, evaluations=evaluations)
