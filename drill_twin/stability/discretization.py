"""Is the growing instability with more degrees of freedom physical or numerical?

Thesis §6.1.2/§6.2 leave open whether the shrinking stable region of finer
discretisations (Liu et al. [40], ch. 4-5) belongs to the continuous drill
string or to the discretisation.  This module computes the rightmost
characteristic roots at *fixed physical parameters* for a sequence of
discretisations of the same string:

* the FEM of App. A with 2, 4, 8, …, 256 elements (BHA share of the elements
  kept at L_b/L), and
* the coupled lumped chains of §5.1 with N = 1, 2, 4, … equal oscillators
  (same total mass, inertia and compliances).
"""
from __future__ import annotations

from ..physics.models import coupled_chain, fem_drill_string
from ..physics.parameters import BitRockGroups, DrillStringSI
from .spectrum import rightmost_roots

__all__ = ['fem_sequence', 'chain_sequence']


def fem_sequence(system: DrillStringSI, groups: BitRockGroups, elements=(2, 4, 8, 16, 32, 64,
                                                                        128, 256),
                 count: int = 6, **fem_kw) -> dict:
    """Rightmost roots of the FEM linearisation for each element count."""
    share = system.bha_length_m / (system.bha_length_m + system.pipe_length_m)
    out = {}
    for n in elements:
        nb = min(max(1, round(n * share)), n - 1)
        model = fem_drill_string(system, elements=n, bha_elements=nb, **fem_kw)
        out[n] = rightmost_roots(model, groups, count=count).roots
    return out


def chain_sequence(groups: BitRockGroups, kappa_d: float, sizes=(1, 2, 4, 8, 16, 32, 64),
                   count: int = 6) -> dict:
    """Rightmost roots of the coupled N-oscillator chains (imposed surface velocities)."""
    return {n: rightmost_roots(coupled_chain(n, kappa_d, groups.psi), groups,
                               count=count).roots for n in sizes}


def plot_sequences(series: dict, path):
    """Spectral abscissa (largest real part) against the number of elements/oscillators.

    ``series`` maps a label to ``{size: roots}``.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for label, seq in series.items():
        sizes = sorted(seq)
        ax1.plot(sizes, [seq[n][0].real for n in sizes], 'o-', label=label)
        ax2.plot(sizes, [abs(seq[n][0].imag) for n in sizes], 'o-', label=label)
    for ax in (ax1, ax2):
        ax.set_xscale('log', base=2)
        ax.set_xlabel('elements / oscillators')
        ax.grid(alpha=0.3)
    ax1.set_ylabel('spectral abscissa  max Re λ  [1/t*]')
    ax2.set_ylabel('|Im λ| of the rightmost root  [rad/t*]')
    ax1.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
