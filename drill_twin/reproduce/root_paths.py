"""Figs 4.2.3 and 4.2.4: the 2-DOF axial chain with equal masses and springs (ε = 0.5).

4.2.3 (a): stability chart over an extended (a, b) region, with its number of
disconnected stable areas (the thesis finds three); (b): the closer chart
with the two paths L1 and L2.  4.2.4: the rightmost characteristic roots
along L1 and L2, from the right end to the left end; where the number of
unstable roots changes, the crossing root's Im(z)/π (the thesis finds
crossings near ±qπ).  The thesis gives only the right end of L2,
(a, b) = (50, 0.3); our choice: L2 is b = 0.3 and L1 is b = 2.96 (the b of
its time responses), both for a from 50 down to b + 0.01 (κ_d = a − b must be
positive; at a = b the zero root appears: the thesis's triangles).
"""
from __future__ import annotations

import numpy as np

from ..config.scenario import load_scenario
from ..plotting import plt
from ..stability.charts import plot_chart, stability_chart
from ..stability.linearize import linearize_scenario
from ..stability.spectrum import rightmost_roots

__all__ = ['FIGURES', 'PATHS', 'root_path']

PATHS = {'L1': 2.96, 'L2': 0.3}   # b of each path; a runs from A_RIGHT down to b + A_GAP
A_GAP = 0.01
A_RIGHT = 50.0
_CONFIG = ('axial_chain_2dof', ['model.n=2', 'model.eps=0.5'])


def root_path(b: float, a_values, count: int = 6):
    """Rightmost roots at each (a, b); returns ``(roots array [len(a), count], crossings)``
    with crossings ``(a, Im(z)/π, 'unstable'|'stable')`` where the unstable count changes."""
    config, base = _CONFIG
    rows, counts, seeds = [], [], None
    for a in a_values:
        sc = load_scenario(config, base + [f'groups.a={a}', f'groups.b={b}'])
        res = rightmost_roots(linearize_scenario(sc), count=count, seeds=seeds)
        r = np.full(count, np.nan + 0j)
        r[:len(res.roots)] = res.roots
        rows.append(r)
        counts.append(int(np.sum(res.roots.real > 1e-9)))
        seeds = res.roots
    roots = np.array(rows)
    crossings = []
    for i in range(1, len(a_values)):
        if counts[i] != counts[i - 1]:
            pair = np.concatenate([roots[i - 1], roots[i]])
            pair = pair[np.isfinite(pair) & (pair.imag >= 0)]
            z = pair[np.argmin(np.abs(pair.real))]
            crossings.append((float(0.5 * (a_values[i] + a_values[i - 1])),
                              float(z.imag / np.pi),
                              'unstable' if counts[i] > counts[i - 1] else 'stable'))
    return roots, crossings


def _stable_areas(chart) -> list:
    """Sizes (grid cells) of the disconnected stable areas, largest first."""
    from scipy import ndimage
    labels, n = ndimage.label(chart.unstable == 0)
    return sorted((int((labels == k).sum()) for k in range(1, n + 1)), reverse=True)


def fig_4_2_3(quick, pool=None):
    config, base = _CONFIG
    raw = load_scenario(config, base).raw
    n = (16, 10) if quick else (120, 80)
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(12, 4.5))
    wide = stability_chart(raw, 'groups.a', np.linspace(0.3, 120.0, n[0]), 'groups.b',
                           np.linspace(0.2, 40.0, n[1]), pool=pool)
    plot_chart(wide, None, title='(a) 2-DOF, ε = 0.5: extended region', ax=ax_a)
    ax_a.set_xlabel('a')
    ax_a.set_ylabel('b')
    close = stability_chart(raw, 'groups.a', np.linspace(0.3, A_RIGHT, n[0]), 'groups.b',
                            np.linspace(0.2, 12.0, n[1]), pool=pool)
    plot_chart(close, None, title='(b) closer look, paths L1 and L2 (crossings: Im z)',
               ax=ax_b)
    ax_b.set_xlabel('a')
    ax_b.set_ylabel('b')
    out = {'stable_area_sizes_extended_cells': _stable_areas(wide),
           'grid': list(n),
           'stable_fraction_extended': float((wide.unstable == 0).mean())}
    for name, b in PATHS.items():
        ax_b.plot([b + A_GAP, A_RIGHT], [b, b], color='k', lw=1.5)
        ax_b.annotate(name, (A_RIGHT, b), textcoords='offset points', xytext=(-18, 4))
        _, crossings = root_path(b, np.linspace(A_RIGHT, b + A_GAP, 40 if quick else 400))
        for a, im, _ in crossings:
            ax_b.annotate(f'{im:.2f}π', (a, b), fontsize=7, rotation=90,
                          textcoords='offset points', xytext=(0, 6))
        out[f'{name} crossings (a, Im/π, becomes)'] = [(round(a, 2), round(im, 3), s)
                                                       for a, im, s in crossings]
    fig.tight_layout()
    return fig, out


def fig_4_2_4(quick, pool=None):
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    out = {}
    for ax, (name, b) in zip(axes, PATHS.items()):
        a_values = np.linspace(A_RIGHT, b + A_GAP, 40 if quick else 400)
        roots, crossings = root_path(b, a_values)
        z = roots[np.isfinite(roots)]
        ax.scatter(z.real, z.imag / np.pi, s=3, c=np.where(z.real > 1e-9, 'tab:red',
                                                              'tab:blue'))
        for _a, im, _ in crossings:
            ax.plot(0.0, im, 'D', color='tab:green', ms=6)
        end = roots[-1][np.isfinite(roots[-1])]
        ax.plot(end.real, end.imag / np.pi, '^', color='k', ms=6, label='a → b')
        ax.axvline(0.0, color='0.5', lw=0.8)
        ax.set_xlim(-3.0, 1.0)
        ax.set_xlabel('Re z')
        ax.set_ylabel('Im z / π')
        ax.set_title(f'rightmost roots along {name} (b = {b}, a = {A_RIGHT:g} → {b})')
        ax.legend(loc='lower left', fontsize=8)
        out[f'{name} crossings Im/π'] = [round(im, 3) for _, im, _ in crossings]
        out[f'{name} right end rightmost root'] = [float(roots[0][0].real),
                                                   float(roots[0][0].imag / np.pi)]
    fig.tight_layout()
    return fig, out


FIGURES = {'4.2.3': fig_4_2_3, '4.2.4': fig_4_2_4}
