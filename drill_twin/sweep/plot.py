"""The figure of a sweep: the stable region and D-curves of a linear sweep; the map of the
first statistic of a nonlinear one with the stick-slip boundary (stick fraction > 0); the
probability of stick-slip of a Monte Carlo sweep."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .store import atomic_write

__all__ = ['plot_sweep']

#: resolution of the sweep figure [dots per inch]
FIGURE_DPI = 110


def plot_sweep(ds, path, title: str = '') -> None:
    """Write the figure of the sweep dataset ``ds`` (:meth:`SweepStore.dataset`) to ``path``."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    x, y = ds['x'].values, ds['y'].values
    if ds.attrs['kind'] == 'linear' and 'sample' not in ds.dims:
        _linear(ax, x, y, ds['unstable'].values, ds['abscissa'].values)
    else:
        field, label = _field(ds)
        if len(y) == 1:
            ax.plot(x, field[0], 'o-')
            ax.set_ylabel(label)
        else:
            mesh = ax.pcolormesh(x, y, field, shading='nearest', cmap='viridis')
            fig.colorbar(mesh, ax=ax, label=label)
            if 'stick_fraction' in ds and 'sample' not in ds.dims:
                stuck = (np.nan_to_num(ds['stick_fraction'].values) > 0).astype(float)
                if 0 < stuck.mean() < 1:
                    ax.contour(x, y, stuck, levels=[0.5], colors='w', linewidths=1.5)
    ax.set_xlabel(ds.attrs['x_key'])
    if len(y) > 1:
        ax.set_ylabel(ds.attrs['y_key'])
    ax.set_title(title or f"{ds.attrs['kind']} sweep")
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format=Path(path).suffix.lstrip('.') or 'png', dpi=FIGURE_DPI)
    plt.close(fig)
    atomic_write(path, buffer.getvalue())    # (a full disk leaves no half a figure)


def _linear(ax, x, y, unstable, abscissa):
    """The chart's own drawing (:func:`~drill_twin.stability.charts.plot_chart`) over the
    spectral abscissa; a one-dimensional sweep as a curve of the unstable-root count."""
    if len(y) == 1:
        ax.plot(x, unstable[0], 'o-')
        ax.set_ylabel('unstable roots')
        return
    from ..stability.charts import ChartResult, plot_chart
    plot_chart(ChartResult('', '', x, y, abscissa, unstable), None, ax=ax, abscissa=True)


def _field(ds):
    if 'stick_slip_probability' in ds:
        return ds['stick_slip_probability'].values, 'probability of stick-slip'
    spec_stats = [k for k in ds.data_vars if ds[k].dims == ('y', 'x') and k != 'run']
    name = spec_stats[0]
    return ds[name].values, name
