"""Stability charts over two parameters, with D-curves, computed in parallel.

A chart evaluates, on a grid of two configuration keys, the rightmost
characteristic roots of the linearised model and the *number of roots in the
right half-plane* (the structural zero root excluded).  That number is
piecewise constant and changes exactly where a root crosses the imaginary
axis, so the D-curves of the thesis (loci of imaginary roots, §4.2.2) are the
contour lines of this integer field at half-integer levels; the stable region
is where it is zero (shaded).

Keys are dotted configuration keys (``groups.a``, ``groups.omega_o``,
``operating_point.surface_speed_rad_s`` …) plus the virtual key
``upsilon_o``: the dimensionless penetration rate, realised by setting
``W_o = n_b λ + 2π υ_o/ω_o`` (eq. 2.4.5) at each point.

Rows of the grid are distributed over worker processes; along a row the roots
of the previous point seed the Newton refinement of the next one (work reused
between neighbours, and a guard against a root the collocation resolves
poorly).
"""
from __future__ import annotations

import math
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..config.scenario import apply_overrides, scenario_from_dict
from ..errors import ParameterError
from .linearize import linearize_scenario
from .spectrum import rightmost_roots

__all__ = ['ChartResult', 'parse_axis', 'stability_chart', 'plot_chart', 'chart_pool']


@dataclass
class ChartResult:
    """Chart data: ``abscissa[iy, ix]`` and ``unstable[iy, ix]`` on ``x`` × ``y``."""

    x_key: str
    y_key: str
    x: np.ndarray
    y: np.ndarray
    abscissa: np.ndarray
    unstable: np.ndarray

    def save(self, path):
        np.savez_compressed(path, x=self.x, y=self.y, abscissa=self.abscissa,
                            unstable=self.unstable, x_key=self.x_key, y_key=self.y_key)


def parse_axis(spec: str):
    """``KEY:MIN:MAX:N`` → (key, values)."""
    try:
        key, lo, hi, n = spec.rsplit(':', 3)
        values = np.linspace(float(lo), float(hi), int(n))
    except ValueError:
        raise ParameterError(f'axis {spec!r} is not KEY:MIN:MAX:N') from None
    if int(n) < 2 or not np.all(np.isfinite(values)):
        raise ParameterError(f'axis {spec!r} needs N >= 2 and finite bounds')
    return key, values


def _point(raw, x_key, x, y_key, y):
    overrides = [f'{k}={v!r}' for k, v in ((x_key, x), (y_key, y)) if k != 'upsilon_o']
    sc = scenario_from_dict(apply_overrides(raw, overrides))
    g = sc.groups
    ups = x if x_key == 'upsilon_o' else (y if y_key == 'upsilon_o' else None)
    if ups is not None:
        g = g.replace(W_o=g.n_b * g.lam + 2 * math.pi * ups / g.omega_o)
    return linearize_scenario(sc, g)


def _row(args):
    raw, x_key, xs, y_key, y, count, order, threshold = args
    absc = np.empty(len(xs))
    unst = np.empty(len(xs), dtype=np.int64)
    seeds = None
    for i, x in enumerate(xs):
        try:
            dde = _point(raw, x_key, float(x), y_key, float(y))
        except ValueError:
            absc[i], unst[i] = np.nan, -1   # no drilling / invalid point
            seeds = None
            continue
        res = rightmost_roots(dde, count=count, order=order, seeds=seeds)
        absc[i] = res.abscissa
        unst[i] = int(np.sum(res.roots.real > threshold))
        seeds = res.roots
    return absc, unst


def chart_pool(workers: int | None = None) -> ProcessPoolExecutor:
    """A process pool for charts.  'spawn' start method: forking a process whose
    BLAS thread pool is already running can deadlock the children."""
    return ProcessPoolExecutor(max_workers=workers or os.cpu_count(),
                               mp_context=multiprocessing.get_context('spawn'))


def stability_chart(raw: dict, x_key: str, xs, y_key: str, ys, workers: int | None = None,
                    count: int = 16, order: int | None = None,
                    threshold: float = 1e-9, pool: ProcessPoolExecutor | None = None
                    ) -> ChartResult:
    """Evaluate the chart of configuration ``raw`` (a YAML mapping) on ``xs`` × ``ys``.

    A root counts as unstable when its real part exceeds ``threshold`` (units
    1/t*).  The default 1e-9 is strict; a positive threshold separates the
    fast (axial) regime from the slow torsional growth of the undamped RGD
    family (Depouhon & Detournay [20]), which the thesis's Fig. 5.1.2 does not
    count as unstable.
    """
    xs = np.asarray(xs, float)
    ys = np.asarray(ys, float)
    jobs = [(raw, x_key, xs, y_key, float(y), count, order, threshold) for y in ys]
    chunk = max(1, len(jobs) // 16)
    if pool is not None:
        rows = list(pool.map(_row, jobs, chunksize=chunk))
    elif workers == 1:
        rows = [_row(j) for j in jobs]
    else:
        with chart_pool(workers) as own:
            rows = list(own.map(_row, jobs, chunksize=chunk))
    absc = np.array([r[0] for r in rows])
    unst = np.array([r[1] for r in rows])
    return ChartResult(x_key, y_key, xs, ys, absc, unst)


def plot_chart(chart: ChartResult, path, title: str = '', ax=None, color='tab:blue',
               label=None, d_curves: bool = True, abscissa: bool = False):
    """Shade the stable region, draw the D-curves (changes of the unstable-root count);
    with ``abscissa`` the spectral abscissa as colour beneath (D-curves then white)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(6.4, 5.0))
    X, Y = np.meshgrid(chart.x, chart.y)
    if abscissa:
        mesh = ax.pcolormesh(chart.x, chart.y, chart.abscissa, shading='nearest', cmap='magma')
        ax.figure.colorbar(mesh, ax=ax, label='spectral abscissa [1/t*]')
    stable = (chart.unstable == 0).astype(float)
    if stable.any():
        ax.contourf(X, Y, stable, levels=[0.5, 1.5], colors=[color], alpha=0.35)
    # complex pairs change the count by 2 and real roots by 1: contour the number
    # of crossing *events* so that each D-curve is drawn once
    pairs = (np.where(chart.unstable < 0, 0, chart.unstable) + 1) // 2
    top = max(int(np.nanmax(pairs)), 1)
    cs = ax.contour(X, Y, pairs.astype(float), levels=np.arange(0.5, top + 0.5, 1.0),
                    colors='w' if abscissa else 'k', linewidths=0.6) if d_curves else None
    if label:
        ax.plot([], [], color=color, lw=6, alpha=0.35, label=label)
    ax.set_xlabel(chart.x_key)
    ax.set_ylabel(chart.y_key)
    if title:
        ax.set_title(title)
    if own:
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return cs
