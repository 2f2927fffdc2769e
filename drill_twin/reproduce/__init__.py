"""Reproduce the thesis's computable figures (``drill-twin reproduce``).

Time-domain figures: :mod:`.time_figures`; root paths (4.2.3, 4.2.4):
:mod:`.root_paths`; stability charts: :mod:`drill_twin.stability.gallery`.
Each figure is written as ``fig_<id>.png`` with its numbers in
``reproduction.json`` (what docs/reproduction.md compares with the thesis).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from ..errors import ParameterError

__all__ = ['FIGURE_IDS', 'reproduce']

FIGURE_IDS = ('3.3.2', '3.3.3', '3.3.4', '4.1.1b', '4.1.2', '4.2.2', '4.2.3', '4.2.4', '4.2.5',
              '4.3.1', '4.3.2', '4.4.1', '5.1.2', '5.1.3', '5.1.4', '5.1.5', '5.1.6', '5.2.2',
              'B.3.1')


def _png(fig_id: str) -> str:
    return f'fig_{fig_id.replace(".", "_")}.png'


def reproduce(out_dir, figures=None, quick: bool = False, workers=None, progress=None) -> dict:
    """Regenerate the figures (all by default) into ``out_dir``; returns their numbers.

    ``quick``: short runs and coarse charts (smoke tests, seconds per figure).
    ``progress(fraction, label)`` is called after each figure.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from ..stability import gallery
    from ..stability.charts import chart_pool
    from . import root_paths, time_figures

    wanted = list(figures or FIGURE_IDS)
    unknown = [f for f in wanted if f not in FIGURE_IDS]
    if unknown:
        raise ParameterError(f'unknown figure(s) {unknown}; known: {", ".join(FIGURE_IDS)}')
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary_path = out / 'reproduction.json'
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else {}
    plt.rcParams.update({'font.size': 11, 'axes.titlesize': 11, 'figure.dpi': 100})
    n_chart = (12, 8) if quick else (90, 60)
    needs_pool = any(f in gallery.FIGURES or f in root_paths.FIGURES for f in wanted)
    pool = chart_pool(workers) if needs_pool else None
    try:
        for k, fig_id in enumerate(wanted):
            t0 = time.perf_counter()
            if fig_id in gallery.FIGURES:
                numbers = {}
                gallery.draw_figure(out, fig_id, n_chart, pool, numbers, plt)
            else:
                if fig_id in root_paths.FIGURES:
                    fig, numbers = root_paths.FIGURES[fig_id](quick, pool)
                else:
                    fig, numbers = time_figures.FIGURES[fig_id](quick)
                fig.suptitle(f'Thesis Fig. {fig_id} (drill_twin)', fontsize=12)
                fig.tight_layout()
                fig.savefig(out / _png(fig_id), dpi=100)
                plt.close(fig)
            summary[fig_id] = {'png': _png(fig_id), 'quick': quick,
                               'wall_s': round(time.perf_counter() - t0, 2),
                               'numbers': numbers}
            if progress:
                progress((k + 1) / len(wanted), fig_id)
    finally:
        if pool is not None:
            pool.shutdown()
    summary_path.write_text(json.dumps(summary, indent=1, default=float))
    return {f: summary[f] for f in wanted}
