"""Quick-look plots (matplotlib, Agg backend): bit velocities with stick phases shaded."""
from __future__ import annotations

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ['plot_bit_velocities']


def _stick_spans(t, stuck):
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
        for a, b in _stick_spans(t, np.asarray(s['angular_stick']) > 0.5):
            ax.axvspan(a, b, color='0.85', lw=0)
        ax.set_title(title)
        ax.set_xlabel(time_label)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
