"""Quick-look plots (matplotlib, Agg backend): bit velocities with stick phases shaded."""
from __future__ import annotations

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ['plot_bit_velocities', 'plot_recording', 'stick_spans', 'plt']


def stick_spans(t, stuck):
    """(start, end) times of the runs where ``stuck`` is true."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], stuck.astype(int), [0]])))
    return [(t[a], t[min(b, len(t) - 1)]) for a, b in zip(edges[::2], edges[1::2])]


def plot_bit_velocities(runs: dict, path, time_label='time [s]'):
    """One panel per run: bit angular speed (right axis) and axial speed (left).

    ``runs`` maps a title to a mapping with ``time``, ``bit_axial_speed``,
    ``bit_angular_speed`` and ``angular_stick`` arrays.
    """
    fig, axes = plt.subplots(len(runs), 1, figsize=(10, 3.2 * len(runs)), squeeze=False)
    for ax, (title, s) in zip(axes[:, 0], runs.items()):
        t = np.asarray(s['time'])
        ax.plot(t, s['bit_axial_speed'], color='tab:blue', lw=0.6, label='bit axial speed')
        ax.set_ylabel('axial speed [m/s]', color='tab:blue')
        ax2 = ax.twinx()
        ax2.plot(t, s['bit_angular_speed'], color='tab:red', lw=0.6, label='bit angular speed')
        ax2.set_ylabel('angular speed [rad/s]', color='tab:red')
        for a, b in stick_spans(t, np.asarray(s['angular_stick']) > 0.5):
            ax.axvspan(a, b, color='0.85', lw=0)
        ax.set_title(title)
        ax.set_xlabel(time_label)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_recording(series: dict, path, title: str = ''):
    """Quick look at a recorded run: bit and surface speed, WOB, TOB, ROP against time,
    angular stick phases shaded.

    ``series`` maps ``time_s``, ``bit_angular_speed_rad_s``,
    ``surface_speed_rad_s``, ``weight_on_bit_N``, ``torque_on_bit_Nm``,
    ``rate_of_penetration_m_s``, ``stuck`` to arrays (absent keys are skipped).
    """
    panels = [(('bit_angular_speed_rad_s', 'bit'), ('surface_speed_rad_s', 'surface'),
               'angular speed [rad/s]'),
              (('weight_on_bit_N', 'WOB'), None, 'weight on bit [N]'),
              (('torque_on_bit_Nm', 'TOB'), None, 'torque on bit [N m]'),
              (('rate_of_penetration_m_s', 'ROP'), None, 'rate of penetration [m/s]')]
    t = np.asarray(series['time_s'])
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 9), sharex=True)
    spans = stick_spans(t, np.asarray(series['stuck']) > 0.5) if 'stuck' in series else []
    for ax, (first, second, label) in zip(axes, panels):
        for key, name in (first, second) if second else (first,):
            if key in series:
                ax.plot(t, series[key], lw=0.7, label=name)
        for a, b in spans:
            ax.axvspan(a, b, color='0.85', lw=0)
        ax.set_ylabel(label)
        if second:
            ax.legend(loc='upper right', fontsize=8)
    axes[0].set_title(title + ('  (stick phases shaded)' if spans else ''))
    axes[-1].set_xlabel('time [s]')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
