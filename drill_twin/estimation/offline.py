"""The estimator over a recording (``drill-twin estimate RUN.mcap``).

The surface topics of an MCAP recording (the twin's, or a rig's recorded under the same
names) are the samples, in log-time order; the sample rate is the recording's (the median
spacing of ``surface/torque``).  Where the recording also has the twin's bit topics, they
are the truth and the errors are computed as in :mod:`.study`.

Every value read must be a number in the field the twin writes (``data`` of a
``std_msgs/msg/Float64`` ...): a topic that carries text or another message type is a
:class:`~drill_twin.io.mcap_reader.RecordingError` naming the topic, its type and the
type expected.  A recorded NaN is a sample the gate refuses (and counts); an instant at
which a channel was not recorded holds its last value without counting.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from ..io.mcap_reader import RecordingError
from ..topics import BY_NAME
from .estimator import DownholeEstimator, EstimatorTuning, SensorNoise, estimate_series
from .study import f1_score, stick_windows
from .surface_gate import CHANNELS, SurfaceGate

__all__ = ['recording_series', 'estimate_recording', 'recording_errors', 'plot_estimate']

_SURFACE = {'speed': ('surface/top_drive_speed', 'data'), 'torque': ('surface/torque', 'data'),
            'hook_load': ('surface/hook_load', 'data'),
            'block_velocity': ('surface/block_velocity', 'data')}
_TRUTH = {'bit_speed': ('bit/velocity', 'twist.angular.x'),
          'torque_on_bit': ('bit/wrench', 'wrench.torque.x'),
          'weight_on_bit': ('bit/wrench', 'wrench.force.x'),
          'stuck': ('bit/stuck', 'data'),
          'severity': ('bit/stick_slip_severity', 'data')}


def _field(rec, topic: str, short: str, msg, path: str) -> float:
    """The number at ``path`` of a decoded message; a missing field or a value that is not
    a number (text, a list, a nested message) is a :class:`RecordingError`."""
    value = msg
    for part in path.split('.'):
        value = getattr(value, part, _NO_FIELD)
    expected = BY_NAME[short].type
    number = isinstance(value, (int, float, np.integer, np.floating)) and (
        not isinstance(value, (bool, np.bool_)) or expected == 'std_msgs/msg/Bool')
    if not number:
        got = 'no such field' if value is _NO_FIELD else \
            f'{type(value).__name__} {repr(value)[:40]}'
        raise RecordingError(f'{rec.path}: topic {topic} is {rec.topics[topic]}: its {path} '
                             f'is not a number ({got}); the estimator reads {expected}')
    return float(value)


_NO_FIELD = object()


def recording_series(rec) -> dict:
    """Surface (and, if recorded, bit) series of a recording on the instants at which both
    the top-drive speed and the surface torque were recorded; ``time_s`` is log time.
    ``recorded`` maps each surface channel to a boolean array: where it was recorded at
    that instant (its value is NaN where not)."""
    ns = rec.run.get('namespace', '/').rstrip('/')
    wanted = {**_SURFACE, **_TRUTH}
    topics = {f'{ns}/{topic}' for topic, _ in wanted.values()}
    missing = [f'{ns}/{_SURFACE[k][0]}' for k in ('speed', 'torque')
               if f'{ns}/{_SURFACE[k][0]}' not in rec.topics]
    if missing:
        raise ParameterError(f'{rec.path}: no {" or ".join(missing)} topic to estimate from')
    by_time: dict[int, dict] = {}
    for topic, t_ns, msg in rec.decoded(sorted(topics & set(rec.topics))):
        short = topic[len(ns) + 1:] if ns else topic.lstrip('/')
        row = by_time.setdefault(t_ns, {})
        for key, (name, path) in wanted.items():
            if name == short:
                row[key] = _field(rec, topic, short, msg, path)
    times = sorted(t for t, row in by_time.items() if 'speed' in row and 'torque' in row)
    if len(times) < 10:
        raise ParameterError(f'{rec.path}: fewer than 10 samples of surface speed and torque')
    out = {'time_s': np.array(times) * 1e-9, 'recorded': {}}
    for key in wanted:
        present = [key in by_time[t] for t in times]
        if any(present):
            out[key] = np.array([by_time[t].get(key, math.nan) for t in times])
            if key in _SURFACE:
                out['recorded'][key] = np.array(present)
    return out


def estimate_recording(series: dict, scenario, tuning: EstimatorTuning | None = None,
                       noise: SensorNoise | None = None, tune_every_s: float = 120.0,
                       progress=None, source: str = 'the recording') -> dict:
    """Run the estimator over the series of :func:`recording_series`; the rate is the
    median sample spacing (samples are taken as one period apart).  ``progress`` as
    :meth:`DownholeEstimator.run`; ``source`` names the recording in errors."""
    dt = float(np.median(np.diff(series['time_s'])))
    if not dt > 0:
        raise ParameterError(f'{source}: no increasing sample times')
    rate = 1.0 / dt
    tuning = tuning or EstimatorTuning()
    est = DownholeEstimator(scenario, min(max(rate, 1.0), 10000.0), noise or SensorNoise(),
                            tuning)
    samples, gate = gated_samples(series)
    if len(samples) < 2:
        refused = ', '.join(f'{k} {n}' for k, n in gate.rejected.items() if n) or 'none'
        raise ParameterError(f'{source}: no acceptable surface speed and torque '
                             f'sample to start from (refused samples: {refused}; '
                             'non-finite or beyond any rig)')
    est.start(samples[0])
    result = estimate_series(est.run(samples[1:], tune_every_s, progress=progress))
    result['time_s'] = series['time_s'][1:]
    result['rate_hz'] = rate
    result['fits'] = [(series['time_s'][0] + t, fit) for t, fit in est.fits]
    result['rejected'] = {k: v for k, v in gate.rejected.items() if v}
    return result


def gated_samples(series: dict) -> tuple[list, SurfaceGate]:
    """The series as samples through a :class:`SurfaceGate` (a refused or missing value
    holds the channel's last acceptable one; a recorded NaN is refused and counted), from
    the first instant with an acceptable speed and torque: the series is trimmed to it in
    place.  ``series['recorded']`` (optional) says where each surface channel was
    recorded; without it every value of a channel present is a recorded one."""
    gate = SurfaceGate()
    size = series['time_s'].size
    nan, absent = np.full(size, math.nan), np.zeros(size, dtype=bool)
    recorded = series.get('recorded', {})
    columns = [series.get(key, nan) for key in _SURFACE]      # in the order of CHANNELS
    taken = [recorded.get(key, absent if key not in series else ~absent) for key in _SURFACE]
    samples = []
    for i, row in enumerate(zip(*columns)):
        for channel, value, mask in zip(CHANNELS, row, taken):
            if mask[i]:
                gate.offer(channel, value)
        samples.append(gate.sample())
    first = next((i for i, s in enumerate(samples) if s is not None), len(samples))
    for key, value in series.items():
        series[key] = {k: v[first:] for k, v in value.items()} if key == 'recorded' else \
            value[first:]
    return samples[first:], gate


def recording_errors(series: dict, est: dict, skip_s: float = 10.0) -> dict | None:
    """Errors against the recorded bit topics (None if the recording has none): RMS bit
    speed error / mean bit speed, stick F1 per 0.1 s window, largest severity error
    (against the twin's own ``bit/stick_slip_severity``), RMS torque and weight on bit."""
    if 'bit_speed' not in series:
        return None
    sel = est['time_s'] >= est['time_s'][0] + skip_s
    if sel.sum() < 10:
        raise ParameterError(f'the recording is shorter than {skip_s:g} s + 10 samples: '
                             'too short to compare')
    truth = {k: v[1:][sel] for k, v in series.items() if k not in ('time_s', 'recorded')}
    speed = truth['bit_speed']
    out = {'samples': int(sel.sum()), 'rate_hz': est['rate_hz'],
           'mean_bit_speed_rad_s': float(speed.mean()),
           'bit_speed_rms_rel': float(np.sqrt(np.mean((est['bit_speed_rad_s'][sel] - speed)
                                                      ** 2)) / abs(speed.mean()))}
    if 'stuck' in truth:
        per = max(1, round(0.1 * est['rate_hz']))
        out['stick_f1'] = f1_score(stick_windows(truth['stuck'] > 0.5, per),
                                   stick_windows(est['stuck'][sel], per))[0]
        out['stick_fraction'] = float(np.mean(truth['stuck'] > 0.5))
    if 'severity' in truth:
        out['severity_max_error'] = float(np.max(np.abs(est['stick_slip_severity'][sel]
                                                        - truth['severity'])))
    for key, unit in (('torque_on_bit', 'Nm'), ('weight_on_bit', 'N')):
        name = f'{key}_{unit}'
        if key in truth and np.isfinite(est[name][sel]).all():
            out[f'{key}_rms_{unit}'] = float(np.sqrt(np.mean((est[name][sel] - truth[key])
                                                             ** 2)))
    return out


def _speed_panel(ax, series, est, lo, hi):
    t = est['time_s']
    w = (t >= lo) & (t <= hi)
    band = 2 * est['bit_speed_std'][w]
    ax.fill_between(t[w], est['bit_speed_rad_s'][w] - band, est['bit_speed_rad_s'][w] + band,
                    color='tab:orange', alpha=0.25, lw=0, label='estimate ±2σ')
    if 'bit_speed' in series:
        ws = (series['time_s'] >= lo) & (series['time_s'] <= hi)
        ax.plot(series['time_s'][ws], series['bit_speed'][ws], 'k', lw=0.8,
                label='twin (truth)')
        if 'stuck' in series:
            ax.fill_between(series['time_s'][ws], 0, 1, where=series['stuck'][ws] > 0.5,
                            color='tab:red', alpha=0.2, lw=0,
                            transform=ax.get_xaxis_transform(), label='stuck (truth)')
    ax.plot(t[w], est['bit_speed_rad_s'][w], color='tab:orange', lw=0.8, label='estimate')
    ax.fill_between(t[w], 0, 0.08, where=est['stuck'][w], color='tab:blue', alpha=0.6, lw=0,
                    transform=ax.get_xaxis_transform(), label='stuck (estimate)')
    ax.set_ylabel('bit speed [rad/s]')
    ax.set_xlim(lo, hi)


def plot_estimate(series: dict, est: dict, path, title: str = ''):
    """Truth (if recorded) against estimate: bit speed with its ±2σ band over the whole
    run and over its last 10 s, stick phases marked (truth: shaded; estimate: bar at the
    bottom), torque on bit below."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    t = est['time_s']
    fig, (ax1, ax0, ax2) = plt.subplots(3, 1, figsize=(10, 8.5))
    _speed_panel(ax1, series, est, t[0], t[-1])
    _speed_panel(ax0, series, est, max(t[0], t[-1] - 10.0), t[-1])
    ax0.set_title('last 10 s', fontsize=9)
    ax0.legend(loc='upper right', fontsize=8, ncol=3)
    if 'torque_on_bit' in series:
        ax2.plot(series['time_s'], series['torque_on_bit'] / 1e3, 'k', lw=0.8, label='twin')
    ax2.plot(t, est['torque_on_bit_Nm'] / 1e3, color='tab:orange', lw=0.8, label='estimate')
    ax2.set_ylabel('torque on bit [kN·m]')
    ax2.set_xlabel('time [s]')
    ax2.legend(loc='upper right', fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
