"""Time-domain figures of the thesis (ch. 3-5), each from its stated parameters.

Every function takes ``quick`` (a shorter run, for the smoke tests) and
returns ``(figure, numbers)``; ``numbers`` are what docs/reproduction.md
compares with the thesis (onset times, amplitudes, frequencies, phase).
Time is in units of t* and velocities dimensionless, as in the thesis plots.
"""
from __future__ import annotations

import functools

import numpy as np

from ..config.scenario import load_scenario
from ..physics.simulation import Simulation
from ..plotting import plt, stick_spans

__all__ = ['FIGURES']


def _run(config, overrides=(), duration=None, interval=None, record_state=False,
         perturb=None):
    """Scenario run as the configuration says (its perturbation unless ``perturb``)."""
    sc = load_scenario(config, list(overrides))
    sim = Simulation.from_scenario(sc, perturbation=perturb)
    tr = sim.run(duration or sc.duration, interval or sc.record_interval,
                 record_state=record_state)
    return sc, sim, tr


def _first(tau, mask):
    return float(tau[np.argmax(mask)]) if np.any(mask) else None


def _mean_stick_duration(tr, window):
    spans = stick_spans(tr.tau[window], tr.angular_stick[window] > 0.5)
    return float(np.mean([b - a for a, b in spans])) if spans else 0.0


def _velocity_axes(ax, tr, title):
    ax.plot(tr.tau, tr.bit_axial_speed, color='tab:blue', lw=0.6)
    ax.set_ylabel('υ_o + υ (axial)', color='tab:blue')
    ax2 = ax.twinx()
    ax2.plot(tr.tau, tr.bit_angular_speed, color='tab:red', lw=0.6)
    ax2.set_ylabel('ω_o + ω (angular)', color='tab:red')
    for a, b in stick_spans(tr.tau, tr.angular_stick > 0.5):
        ax.axvspan(a, b, color='0.85', lw=0)
    ax.set_xlabel('τ (units of t*)')
    ax.set_title(title)
    return ax2


@functools.lru_cache(maxsize=4)  # Fig. 3.3.4 reuses the runs of 3.3.2 and 3.3.3
def _benchmark(overrides: tuple, quick):
    sc, sim, tr = _run('benchmark_fem', overrides, duration=(150.0 if quick else 1500.0),
                       interval=0.05)
    stick = tr.angular_stick > 0.5
    first = _first(tr.tau, stick)
    after = tr.tau >= (first or np.inf)
    return sc, tr, {
        't_star_s': sc.scales.time_s,
        'first_axial_stick_tau': _first(tr.tau, tr.axial_mode == 2),
        'first_angular_stick_tau': first,
        'first_angular_stick_s': first * sc.scales.time_s if first else None,
        'stick_fraction_after_first_stick': float(stick[after].mean()) if first else 0.0,
        'bit_speed_max_over_omega_o': float(tr.bit_angular_speed.max() / sc.groups.omega_o),
        'events': sim.event_count}


#: the thesis's integration scheme and the choices it leaves open, and what they do to the
#: onset of stick-slip.  Forward Euler at h = 1e-4 simulates the damping ϑ - h
#: (|1 + hμ|² = 1 + hω²(h - ϑ), docs/physics.md): ϑ_u 5e-4 -> 4e-4, ϑ_φ 1e-4 -> 0.
_SENSITIVITY = {
    'as configured': [],
    "thesis's Euler scheme (effective damping)": ['model.theta_u=4e-4', 'model.theta_phi=0'],
    'perturbation x10': [f'simulation.initial_perturbation.{k}={v}' for k, v in
                         (('u', 0.1), ('v', 0.1), ('phi', 1.0), ('omega', 1.0))],
    'no Rayleigh damping': ['model.theta_u=0', 'model.theta_phi=0'],
    'no damping, perturbation x10': ['model.theta_u=0', 'model.theta_phi=0'] + [
        f'simulation.initial_perturbation.{k}={v}' for k, v in
        (('u', 0.1), ('v', 0.1), ('phi', 1.0), ('omega', 1.0))],
    '116 elements': ['model.elements=116', 'model.bha_elements=20'],
}


def _onset_sensitivity(drive_overrides, quick):
    """First angular stick [s] for each variant of :data:`_SENSITIVITY` (full runs only)."""
    if quick:
        return {}
    out = {}
    for label, ov in _SENSITIVITY.items():
        sc, _, tr = _run('benchmark_fem', drive_overrides + ov, duration=2000.0, interval=0.05)
        first = _first(tr.tau, tr.angular_stick > 0.5)
        out[label] = round(first * sc.scales.time_s, 1) if first else None
    return {'first_angular_stick_s by variant (2000 t*)': out}


def fig_3_3_2(quick):
    sc, tr, out = _benchmark((), quick)
    out = dict(out)  # the cached run's numbers stay as they are
    fig, ax = plt.subplots(figsize=(9, 4))
    _velocity_axes(ax, tr, 'Benchmark (FEM 58 elements, speed drive): bit velocities')
    out.update(_onset_sensitivity([], quick))
    return fig, out


def fig_3_3_3(quick):
    drive = ['model.top_drive=soft_torque']
    sc, tr, out = _benchmark(tuple(drive), quick)
    out = dict(out)
    fig, ax = plt.subplots(figsize=(9, 4))
    _velocity_axes(ax, tr, 'Benchmark with the Soft-Torque drive: bit velocities')
    out.update(_onset_sensitivity(drive, quick))
    return fig, out


def fig_3_3_4(quick):
    fig, ax = plt.subplots(figsize=(9, 4))
    out = {}
    for label, ov in (('w/o ST', ()), ('w/ ST', ('model.top_drive=soft_torque',))):
        _, tr, _ = _benchmark(ov, quick)
        ax.plot(tr.tau, tr.delay_residual, lw=0.6, label=label)
        out[f'max_abs_residual_rad {label}'] = float(np.abs(tr.delay_residual).max())
    ax.set_xlabel('τ (units of t*)')
    ax.set_ylabel('residual of eq. 2.4.14 [rad]')
    ax.set_title('Delay search check: residual of the implicit delay equation')
    ax.legend()
    return fig, out


def _dominant_frequency(t, x):
    x = x - x.mean()
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    freqs = np.fft.rfftfreq(len(x), t[1] - t[0])
    return float(2 * np.pi * freqs[1 + np.argmax(spec[1:])])


def fig_4_1_1b(quick):
    sc, sim, tr = _run('rgd_stick_slip', duration=(40.0 if quick else 150.0))
    fig, (ax, ax_zoom) = plt.subplots(1, 2, figsize=(12, 4),
                                      gridspec_kw={'width_ratios': [2, 1]})
    _velocity_axes(ax, tr, 'RGD, W_o=7, λ=5, ω_o=5, ψ=50, β=0.3, n_b=6')
    stick = tr.angular_stick > 0.5
    first = _first(tr.tau, stick)
    # before the first stick: the axial oscillation rides on a nearly constant ω
    w = (tr.tau > 1.0) & (tr.tau < (first or tr.tau[-1]))
    z = w & (tr.tau < tr.tau[w][0] + 3.0)
    ax_zoom.plot(tr.tau[z], tr.bit_axial_speed[z], color='tab:blue', lw=0.8)
    ax_zoom.twinx().plot(tr.tau[z], tr.bit_angular_speed[z], color='tab:red', lw=0.8)
    ax_zoom.set_title('detail: ω nearly constant over axial cycles')
    ax_zoom.set_xlabel('τ')
    axial_w = _dominant_frequency(tr.tau[w], tr.bit_axial_speed[w]) if w.sum() > 64 else None
    # independent reference: the rightmost (unstable, axial) root of the linearisation
    from ..stability.linearize import linearize_scenario
    from ..stability.spectrum import rightmost_roots
    roots = rightmost_roots(linearize_scenario(sc), count=6).roots
    return fig, {'first_angular_stick_tau': first,
                 'axial_frequency_rad_per_t_star': axial_w,
                 'axial_root_of_the_linearisation': [float(roots[0].real),
                                                     float(abs(roots[0].imag))],
                 'torsional_natural_frequency': 1.0,
                 'bit_speed_max_over_omega_o': float(tr.bit_angular_speed.max()
                                                     / sc.groups.omega_o)}


def _chain_response(n, ab, quick, eps=None):
    a, b = ab
    eps = eps if eps is not None else (0.5 if n == 2 else 1.0 / n)
    sc, sim, tr = _run('axial_chain_2dof', [f'model.n={n}', f'model.eps={eps}',
                                            f'groups.a={a}', f'groups.b={b}'],
                       duration=(15.0 if quick else 30.0), interval=0.01, record_state=True,
                       perturb={'u': 1e-9})  # stays in the linear regime for 30 delays
    U = tr.state[:, :n]
    late = tr.tau > tr.tau[-1] * 2 / 3
    env = np.abs(U[:, -1])
    # growth rate: slope of log of the running maximum over one delay (τ1 = 1)
    k = int(round(1.0 / (tr.tau[1] - tr.tau[0])))
    peaks = np.array([env[i:i + k].max() for i in range(0, len(env) - k, k)])
    t_peaks = tr.tau[:len(env) - k:k][:len(peaks)] + 0.5
    sel = t_peaks > tr.tau[-1] / 3
    rate = float(np.polyfit(t_peaks[sel], np.log(peaks[sel]), 1)[0]) if sel.sum() > 2 else None
    corr = np.corrcoef(U[late].T) if n > 1 else np.ones((1, 1))
    from ..stability.linearize import linearize_scenario
    from ..stability.spectrum import rightmost_roots
    return tr, U, {'growth_rate_per_delay': rate,
                   'rightmost_root_real_part': rightmost_roots(
                       linearize_scenario(sc), count=2).abscissa,
                   'min_correlation': float(corr.min()),
                   'correlation_with_bit': [round(float(c), 3) for c in corr[-1]],
                   'stick_slip_events': sim.event_count}


def _chain_figure(n, points, quick):
    fig, axes = plt.subplots(len(points), 1, figsize=(9, 2.8 * len(points)), squeeze=False)
    out = {}
    for ax, ab in zip(axes[:, 0], points):
        tr, U, stats = _chain_response(n, ab, quick)
        for i in range(n):
            ax.plot(tr.tau, U[:, i], lw=0.7, label=f'u{i + 1}' + (' (bit)' if i == n - 1
                                                                   else ''))
        ax.set_title(f'{n} axial oscillators, (a, b) = {ab}')
        ax.set_ylabel('perturbed displacement u')
        if n <= 3:
            ax.legend(loc='upper left', fontsize=8)
        out[f'(a, b) = {ab}'] = stats
    axes[-1, 0].set_xlabel('τ (units of the delay)')
    return fig, out


def fig_4_2_5(quick):
    return _chain_figure(2, [(6.9, 2.96), (3.45, 2.96), (0.35, 0.3)], quick)


def fig_4_3_2(quick):
    return _chain_figure(3, [(6.9, 2.96), (3.45, 2.96)], quick)


def fig_4_4_1(quick):
    return _chain_figure(10, [(6.9, 2.96), (3.45, 2.96)], quick)


@functools.lru_cache(maxsize=4)  # Fig. 5.1.6 reuses the run of 5.1.3
def _rgd2(beta, quick):
    return _run('rgd2_stick_slip', [f'groups.beta={beta}'],
                duration=(40.0 if quick else 150.0), record_state=True)


def _rgd2_figure(beta, quick):
    sc, sim, tr = _rgd2(beta, quick)
    fig, (ax, ax_u, ax_p) = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    _velocity_axes(ax, tr, f'RGD-2: ψ=50, W_o=7, λ=5, n_b=6, ω_o=5, β={beta}')
    ax.set_xlabel('')
    n = 2
    for i in range(n):
        ax_u.plot(tr.tau, tr.state[:, i], lw=0.6, label=f'u{i + 1}')
        ax_p.plot(tr.tau, tr.state[:, 2 * n + i], lw=0.6, label=f'φ{i + 1}')
    ax_u.set_ylabel('axial u_i')
    ax_p.set_ylabel('torsional φ_i [rad]')
    ax_p.set_xlabel('τ (units of t*)')
    for a in (ax_u, ax_p):
        a.legend(loc='upper left', fontsize=8)
    stick = tr.angular_stick > 0.5
    late = tr.tau > tr.tau[-1] / 2
    phi = tr.state[:, 2 * n:3 * n]
    return fig, {'first_angular_stick_tau': _first(tr.tau, stick),
                 'stick_fraction_second_half': float(stick[late].mean()),
                 'mean_stick_duration_second_half': _mean_stick_duration(tr, late),
                 'bit_speed_min_max': [float(tr.bit_angular_speed[late].min()),
                                       float(tr.bit_angular_speed[late].max())],
                 'torsional_correlation_second_half': float(np.corrcoef(phi[late].T)[0, 1])}


def fig_5_1_3(quick):
    return _rgd2_figure(0.3, quick)


def fig_5_1_4(quick):
    return _rgd2_figure(1.3, quick)


def fig_5_1_5(quick):
    fig, axes = plt.subplots(3, 1, figsize=(9, 8))
    out = {}
    for beta, ax in ((0.3, axes[0]), (1.3, axes[2])):
        sc, sim, tr = _run('rgd_stick_slip', [f'groups.beta={beta}'],
                           duration=(40.0 if quick else 150.0))
        _velocity_axes(ax, tr, f'RGD, β = {beta}')
        late = tr.tau > tr.tau[-1] / 2
        out[f'beta={beta}'] = {
            'first_angular_stick_tau': _first(tr.tau, tr.angular_stick > 0.5),
            'stick_fraction_second_half': float((tr.angular_stick[late] > 0.5).mean()),
            'mean_stick_duration_second_half': _mean_stick_duration(tr, late),
            'bit_speed_min_max_second_half': [float(tr.bit_angular_speed[late].min()),
                                              float(tr.bit_angular_speed[late].max())]}
        if beta == 0.3:  # (b) detail: one stick-slip cycle late in the run
            z = tr.tau > tr.tau[-1] - 12.0
            axes[1].plot(tr.tau[z], tr.bit_angular_speed[z], color='tab:red', lw=0.8)
            axes[1].plot(tr.tau[z], tr.bit_axial_speed[z], color='tab:blue', lw=0.8)
            for a, b in stick_spans(tr.tau[z], tr.angular_stick[z] > 0.5):
                axes[1].axvspan(a, b, color='0.85', lw=0)
            axes[1].set_title('β = 0.3, detail (blue axial, red angular)')
    fig.tight_layout()
    return fig, out


def fig_5_1_6(quick):
    sc, sim, tr = _rgd2(0.3, quick)
    stick = tr.angular_stick > 0.5
    first = _first(tr.tau, stick)
    n = 2
    phi = tr.state[:, 2 * n:3 * n]
    t0 = (first or tr.tau[-1]) - 8.0
    z = (tr.tau > t0) & (tr.tau < t0 + 16.0)
    fig, ax = plt.subplots(figsize=(9, 4))
    for i, name in enumerate(('top mass', 'bottom mass (bit)')):
        ax.plot(tr.tau[z], phi[z, i], lw=0.8, label=name)
    for a, b in stick_spans(tr.tau[z], stick[z]):
        ax.axvspan(a, b, color='0.85', lw=0)
    ax.set_xlabel('τ (units of t*)')
    ax.set_ylabel('φ_i: angle relative to steady rotation [rad]')
    ax.set_title('RGD-2, β = 0.3: angular positions around the first stick phase')
    ax.legend()
    before = z & (tr.tau < (first or 0))
    lead = phi[before, 1] - phi[before, 0]
    return fig, {'first_angular_stick_tau': first,
                 'bit_ahead_of_top_before_stick_max_rad': float(lead.max()) if lead.size
                 else None}


FIGURES = {'3.3.2': fig_3_3_2, '3.3.3': fig_3_3_3, '3.3.4': fig_3_3_4,
           '4.1.1b': fig_4_1_1b, '4.2.5': fig_4_2_5, '4.3.2': fig_4_3_2,
           '4.4.1': fig_4_4_1, '5.1.3': fig_5_1_3, '5.1.4': fig_5_1_4,
           '5.1.5': fig_5_1_5, '5.1.6': fig_5_1_6}
