"""Does uneven blade spacing move the axial stability boundary?  (Variable pitch, §6.2)

In machining, cutters with uneven tooth pitch suppress regenerative chatter
(Altintas, ref. [4] of the thesis): each tooth sees a different delay, and the
regenerative feedback no longer adds up in phase.  A drag bit is the same
regenerative system (eq. 2.4.13: each blade cuts what the blade ahead left).

The chart computes the stability region of the 1-DOF axial model of ch. 4,
``u'' + p u' + a u - (b/n_b) Σ_b u(τ - τ_b) = 0`` (the (a, b) plane of Fig. 4.1.2,
time scaled so that the mean delay is 1), for a two-blade bit whose second blade
sits ``180° + δ`` from the first: delays ``(1 ± δ/180)``.  The even bit is δ = 0.
The same multi-delay linearisation serves any blade layout of any model
(:func:`drill_twin.stability.linearize.linearize`).
"""
from __future__ import annotations

import numpy as np

from ..config.scenario import load_scenario
from .charts import stability_chart

__all__ = ['variable_pitch_charts', 'plot_variable_pitch', 'PITCHES_DEG']

#: pitch variations δ [deg] of the second blade away from 180°
PITCHES_DEG = (0.0, 20.0, 40.0, 60.0)


def variable_pitch_charts(n=(120, 80), a=(0.3, 40.0), b=(0.2, 12.0), damping: float = 0.0,
                          pitches=PITCHES_DEG, workers=None, progress=None) -> dict:
    """One stability chart per pitch variation; returns ``{δ: ChartResult}`` and the
    numbers that answer the question (stable fraction of the window, the smallest b that
    is unstable, and that b's mean over a).  ``progress(fraction, detail)`` after each
    chart."""
    xs = np.linspace(*a, n[0])
    ys = np.linspace(*b, n[1])
    out = {}
    for delta in pitches:
        overrides = ['model.n=1', f'model.damping={damping}', 'groups.n_b=2',
                     f'bit.blade_angles_deg=[0, {180.0 + delta}]']
        raw = load_scenario('axial_chain_2dof', overrides).raw
        chart = stability_chart(raw, 'groups.a', xs, 'groups.b', ys, workers=workers)
        unstable = chart.unstable != 0
        lowest = np.array([ys[np.argmax(unstable[:, i])] if unstable[:, i].any() else np.nan
                           for i in range(xs.size)])
        out[delta] = {'chart': chart, 'stable_fraction': float((~unstable).mean()),
                      'min_unstable_b': float(np.nanmin(lowest)),
                      'mean_lowest_unstable_b': float(np.nanmean(lowest))}
        if progress is not None:
            progress(len(out) / len(pitches), f'{len(out)}/{len(pitches)} charts')
    return out


def plot_variable_pitch(results: dict, path):
    """The stable regions of every pitch variation on one chart, and the boundary b(a)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from .charts import plot_chart
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    colors = ('tab:blue', 'tab:orange', 'tab:green', 'tab:red', 'tab:purple')
    for (delta, r), color in zip(results.items(), colors):
        chart = r['chart']
        plot_chart(chart, None, ax=axes[0], color=color, d_curves=False,
                   label=f'δ = {delta:g}°: stable {100 * r["stable_fraction"]:.0f} %')
        unstable = chart.unstable != 0
        lowest = [chart.y[np.argmax(unstable[:, i])] if unstable[:, i].any() else np.nan
                  for i in range(chart.x.size)]
        axes[1].plot(chart.x, lowest, color=color, label=f'δ = {delta:g}°')
    axes[0].set_title('two blades at 0° and 180° + δ: stable regions (shaded)')
    axes[0].legend(fontsize=8, loc='upper left')
    axes[1].set_xlabel('groups.a')
    axes[1].set_ylabel('lowest unstable b')
    axes[1].set_title('the stability boundary b(a)')
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
