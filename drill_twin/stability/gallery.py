"""The stability charts of thesis ch. 4-5, regenerated (``drill-twin stability gallery``).

Each entry: figure id, configuration name, overrides, axes, threshold, caption.
Axes are (x key, min, max) and (y key, min, max); the resolution is set by
the caller (``quick`` for smoke tests).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..config.scenario import load_scenario
from ..errors import ParameterError
from .charts import chart_pool, plot_chart, stability_chart

__all__ = ['FIGURES', 'make_gallery', 'draw_figure']

_AB = (('groups.a', 0.3, 40.0), ('groups.b', 0.2, 12.0))
_VW = (('groups.omega_o', 1.0, 40.0), ('upsilon_o', 0.05, 4.0))
_RGD_13 = ['groups.psi=13.79', 'groups.n_b=4', 'groups.n_b_lambda=4']
# SI benchmark: Ω_o [rad/s] on x; υ_o (dimensionless, via W_o) on y
_VW_SI = (('operating_point.surface_speed_rad_s', 2.0, 60.0), ('upsilon_o', 0.05, 3.0))
_SEMI = ['model.type=semi_infinite']

FIGURES = {
    '4.1.2': [('1-DOF, p = 0', 'axial_chain_2dof', ['model.n=1'], _AB, 1e-9),
              ('1-DOF, p = 1', 'axial_chain_2dof', ['model.n=1', 'model.damping=1.0'], _AB,
               1e-9)],
    # ε = 0.005: the stiff top spring (frequency ~ sqrt(κ_d)/ε ~ 1000 rad/t*) is the
    # rigid limit; resolving it would need order ~1000 per point, so order 64 is used
    # and that mode is left out (it is the ε → 0 limit of the thesis, 1-DOF-like)
    '4.2.2': [(f'2-DOF, ε = {e}', 'axial_chain_2dof', [f'model.eps={e}'], _AB, 1e-9,
               64 if e < 0.01 else None) for e in (0.005, 0.2, 0.5, 0.8)],
    '4.3.1': [(f'3-DOF, ε = {e:.3g}', 'axial_chain_2dof', ['model.n=3', f'model.eps={e}'], _AB,
               1e-9, 64 if e < 0.1 else None) for e in (0.05, 1 / 3)],
    '5.1.2': [('RGD (ψ = 13.79, n_b = 4)', 'rgd_stick_slip', _RGD_13, _VW, 1e-3),
              ('RGD-k (κ_d = 2.5)', 'rgd_stick_slip', _RGD_13 + ['model.type=rgd_k',
                                                               'groups.kappa_d=2.5'], _VW, 1e-3),
              ('RGD-2 (κ_d = 2.5)', 'rgd2_stick_slip', _RGD_13, _VW, 1e-3),
              ('RGD-2, strict (Re λ > 1e-9)', 'rgd2_stick_slip', _RGD_13, _VW, 1e-9)],
    '5.2.2': [('semi-infinite string (benchmark SI)', 'benchmark_fem', _SEMI, _VW_SI, 1e-9)],
    'B.3.1': [('lumped model II (benchmark SI)', 'benchmark_fem', ['model.type=lumped_II'],
               _VW_SI, 1e-9),
              ('lumped model III (benchmark SI)', 'benchmark_fem', ['model.type=lumped_III'],
               _VW_SI, 1e-9),
              ('lumped model I (benchmark SI)', 'benchmark_fem', ['model.type=lumped_I'],
               _VW_SI, 1e-9)],
}


def make_gallery(out_dir, figures=None, quick: bool = False, workers=None, progress=None):
    """Compute and draw the charts; returns a summary dict (stable fractions, times)."""
    unknown = [f for f in figures or () if f not in FIGURES]
    if unknown:
        raise ParameterError(f'unknown figure(s) {", ".join(unknown)}; the gallery has: '
                             f'{", ".join(FIGURES)}')
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    n = (12, 8) if quick else (90, 60)
    summary = {}
    wanted = figures or list(FIGURES)
    with chart_pool(workers) as pool:
        for k, fig_id in enumerate(wanted):
            draw_figure(out, fig_id, n, pool, summary, plt)
            if progress:
                progress((k + 1) / len(wanted))
    (out / 'stability_gallery.json').write_text(json.dumps(summary, indent=1))
    return summary


def draw_figure(out, fig_id, n, pool, summary, plt):
    """Compute and draw the panels of one thesis figure into ``out``."""
    panels = FIGURES[fig_id]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 4.0),
                             squeeze=False)
    for ax, (title, config, overrides, axes_spec, threshold, *order) in zip(axes[0], panels):
        (xk, x0, x1), (yk, y0, y1) = axes_spec
        raw = load_scenario(config, overrides).raw
        t0 = time.perf_counter()
        chart = stability_chart(raw, xk, np.linspace(x0, x1, n[0]), yk,
                                np.linspace(y0, y1, n[1]), pool=pool,
                                threshold=threshold, order=order[0] if order else None)
        if threshold > 1e-9:   # say it in the picture: the shading is a growth threshold
            title += f'\nshaded: every root Re λ < {threshold:g}/t* (not strictly stable)'
        plot_chart(chart, None, title=title, ax=ax)
        summary[f'{fig_id} {title}'] = {
            'stable_fraction': float((chart.unstable == 0).mean()),
            'wall_s': time.perf_counter() - t0, 'threshold': threshold}
    fig.suptitle(f'Thesis Fig. {fig_id}: shaded where no root lies right of the panel\'s '
                 'threshold; D-curves in black')
    fig.tight_layout()
    fig.savefig(out / f'fig_{fig_id.replace(".", "_")}.png', dpi=100)
    plt.close(fig)
