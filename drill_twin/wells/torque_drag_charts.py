"""The drilling engineer's two pictures of a string in its well (docs/torque_drag.md).

* The hook-load "broomstick": pick-up, slack-off and rotating hook load off bottom
  against bit depth, one curve per friction factor (the curves part where the hole
  deviates: drag adds to the pick-up load and takes from the slack-off load).
* The torque profile: tension, wall contact force and torque along the string at the
  configured bit depth, rotating off and on bottom (the configuration's WOB and the
  torque on bit of its steady state).
"""
from __future__ import annotations

import numpy as np

from ..config.well import scenario_well
from ..errors import ParameterError
from ..physics.torque_drag import ROTATING, broomstick, torque_drag

__all__ = ['well_charts', 'plot_broomstick', 'plot_profile']


def well_charts(scenario, friction_factors, depths: int = 40) -> dict:
    """Broomstick data over ``depths`` bit depths and the profiles at the string's own
    length, for an SI ``scenario`` (its ``well`` section, its string and mud)."""
    if not scenario.is_si:
        raise ParameterError('drill-twin well needs an SI configuration (a physical string)')
    system = scenario.system
    path = scenario_well(scenario)
    length = system.total_length_m
    if not 2 <= depths <= 1000:
        raise ParameterError(f'--depths {depths}: must be in [2, 1000]')
    bit_depths = np.linspace(length / depths, length, depths)
    chart = broomstick(path, system.sections, bit_depths, system.mud_density_kg_m3,
                       friction_factors)
    mu = float((scenario.raw.get('well') or {}).get('friction_factor', 0.25))
    wob = scenario.groups.W_o * scenario.scales.force_N
    tob = scenario.groups.T_o * scenario.scales.torque_Nm
    off = torque_drag(path, system.sections, length, mu, ROTATING, system.mud_density_kg_m3)
    on = torque_drag(path, system.sections, length, mu, ROTATING, system.mud_density_kg_m3,
                     weight_on_bit_N=wob, torque_on_bit_Nm=tob)
    return {'path': path, 'chart': chart, 'friction_factor': mu, 'off_bottom': off,
            'on_bottom': on, 'weight_on_bit_N': wob, 'torque_on_bit_Nm': tob}


def plot_broomstick(chart, path) -> None:
    """Hook load [kN] (x) against bit depth [m] (y, down), per friction factor."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 7))
    colours = plt.cm.viridis(np.linspace(0.1, 0.85, chart.friction_factor.size))
    for i, (mu, c) in enumerate(zip(chart.friction_factor, colours)):
        ax.plot(chart.pick_up_N[i] / 1e3, chart.bit_depth_m, color=c, label=f'μ = {mu:g}')
        ax.plot(chart.slack_off_N[i] / 1e3, chart.bit_depth_m, color=c, ls='--')
    ax.plot(chart.rotating_N[0] / 1e3, chart.bit_depth_m, color='k', lw=1.2,
            label='rotating off bottom')
    ax.invert_yaxis()
    ax.set_xlabel('hook load [kN]  (solid: pick-up, dashed: slack-off)')
    ax.set_ylabel('bit measured depth [m]')
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_profile(result: dict, path) -> None:
    """Tension, contact force and torque along the string, rotating off and on bottom."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(11, 6), sharey=True)
    for label, prof, style in (('off bottom', result['off_bottom'], '-'),
                               ('on bottom', result['on_bottom'], '--')):
        md = prof.measured_depth_m
        axes[0].plot(prof.tension_N / 1e3, md, style, label=label)
        axes[1].plot(prof.normal_force_N_m, md, style, label=label)
        axes[2].plot(prof.torque_Nm / 1e3, md, style, label=label)
    for ax, xlabel in zip(axes, ('tension [kN]', 'wall contact force [N/m]',
                                 'torque [kN m]')):
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
    axes[0].invert_yaxis()
    axes[0].set_ylabel('measured depth [m]')
    axes[2].legend(fontsize=8)
    fig.suptitle(f"rotating, μ = {result['friction_factor']:g}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
