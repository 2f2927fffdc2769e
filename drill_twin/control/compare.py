"""``drill-twin control compare``: every controller mode over surface speed × WOB.

For each mode and grid point: the closed-loop spectral abscissa of the linearisation
(drive + controller + string + bit, :func:`drill_twin.stability.linearize.linearize`) and
the stick-slip statistics of the nonlinear simulation (:func:`drill_twin.physics.
statistics.stick_slip_summary` over the last ``window_s`` of ``duration_s``).  The
stability-tuned gains are tuned once, at the configuration's operating point, and held
over the map — as a drive would be commissioned.  Points run in a process pool.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from ..analysis.statistics import output_series, stick_slip_summary
from ..config.lookup import resolve_config
from ..config.scenario import read_config, scenario_from_dict
from ..physics.simulation import Simulation
from ..physics.top_drive import CONTROLLERS
from ..stability.charts import chart_pool
from ..stability.spectrum import rightmost_roots

__all__ = ['ControlMap', 'compare_modes', 'mode_config', 'plot_maps', 'markdown_table']


@dataclass
class ControlMap:
    """Maps of one mode: ``abscissa_per_s`` and ``severity``, ``stick_fraction`` of shape
    (WOBs, speeds)."""

    mode: str
    speeds_rad_s: np.ndarray
    wobs_N: np.ndarray
    abscissa_per_s: np.ndarray
    severity: np.ndarray
    stick_fraction: np.ndarray
    gains: dict = field(default_factory=dict)

    def lowest_stick_free_speed(self, row: int) -> float | None:
        """Lowest grid speed from which every higher speed runs without a stick phase."""
        free = self.stick_fraction[row] <= 0.0
        if not free[-1]:
            return None
        k = len(free) - 1
        while k > 0 and free[k - 1]:
            k -= 1
        return float(self.speeds_rad_s[k])


def mode_config(raw: dict, mode: str, gains=None) -> dict:
    """The configuration with the motor drive running ``mode`` (explicit gains if given)."""
    cfg = copy.deepcopy(raw)
    cfg.setdefault('model', {})['top_drive'] = 'motor'
    drive = cfg.setdefault('drive', {})
    drive['controller'] = mode
    if gains is not None:
        drive.update({'proportional_gain_Nms_rad': gains.proportional_Nms_rad,
                      'integral_gain_Nm_rad': gains.integral_Nm_rad,
                      'torque_feedback_rad_s_Nm': gains.torque_feedback_rad_s_Nm})
    return cfg


def _point(job):
    cfg, speed, wob, duration_s, window_s = job
    cfg = copy.deepcopy(cfg)
    cfg['operating_point'] = {'surface_speed_rad_s': float(speed), 'weight_on_bit_N': float(wob)}
    sc = scenario_from_dict(cfg, 'control compare')
    t = sc.scales.time_s
    abscissa = rightmost_roots(sc.model, sc.groups, count=4).abscissa / t
    traj = Simulation.from_scenario(sc).run(duration_s / t, 0.01 / t)
    stats = stick_slip_summary(output_series(sc, traj), duration_s - window_s)
    return abscissa, stats['severity'], stats['stick_fraction']


def compare_modes(config: str, speeds_rad_s, wobs_N, duration_s: float = 300.0,
                  window_s: float = 100.0, workers: int | None = None,
                  modes=CONTROLLERS, progress=None) -> list[ControlMap]:
    """The maps of every mode (see module docstring)."""
    raw = read_config(resolve_config(config))
    gains = {}
    for mode in modes:
        sc = scenario_from_dict(mode_config(raw, mode), 'control compare')
        gains[mode] = sc.model.top_drive.gains
    jobs = [(mode_config(raw, m, gains[m]), s, w, duration_s, window_s)
            for m in modes for w in wobs_N for s in speeds_rad_s]
    with chart_pool(workers) as pool:
        results = []
        for i, r in enumerate(pool.map(_point, jobs)):
            results.append(r)
            if progress is not None:
                progress((i + 1) / len(jobs), f'{i + 1}/{len(jobs)} runs')
    arr = np.array(results).reshape(len(modes), len(wobs_N), len(speeds_rad_s), 3)
    return [ControlMap(m, np.asarray(speeds_rad_s, float), np.asarray(wobs_N, float),
                       arr[k, :, :, 0], arr[k, :, :, 1], arr[k, :, :, 2],
                       {'proportional_Nms_rad': gains[m].proportional_Nms_rad,
                        'integral_Nm_rad': gains[m].integral_Nm_rad,
                        'torque_feedback_rad_s_Nm': gains[m].torque_feedback_rad_s_Nm})
            for k, m in enumerate(modes)]


TITLES = {'stiff_pi': 'stiff PI', 'soft_torque': 'Soft-Torque', 'z_torque': 'Z-Torque',
          'stability_tuned': 'stability-tuned'}


def plot_maps(maps: list[ControlMap], path):
    """One panel per mode: stick-slip severity (colour), the nonlinear stick-slip boundary
    (solid: stick phases on the left) and the linear one (dashed: spectral abscissa 0)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    cols = 2
    rows = math.ceil(len(maps) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(10, 4 * rows), squeeze=False,
                             sharex=True, sharey=True)
    vmax = max(float(np.nanmax(m.severity)) for m in maps) or 1.0
    for ax, m in zip(axes.flat, maps):
        X, Y = m.speeds_rad_s, m.wobs_N / 1e3
        mesh = ax.pcolormesh(X, Y, m.severity, shading='nearest', cmap='magma_r', vmin=0,
                             vmax=vmax)
        if len(X) > 1 and len(Y) > 1:
            ax.contour(X, Y, (m.stick_fraction > 0).astype(float), levels=[0.5],
                       colors='tab:cyan', linewidths=2)
            ax.contour(X, Y, m.abscissa_per_s, levels=[0.0], colors='tab:green',
                       linestyles='--')
        ax.set_title(TITLES.get(m.mode, m.mode))
        ax.set_xlabel('surface speed [rad/s]')
        ax.set_ylabel('WOB [kN]')
    for ax in list(axes.flat)[len(maps):]:
        ax.set_visible(False)
    fig.colorbar(mesh, ax=axes, label='stick-slip severity (max-min)/(2 mean)')
    fig.suptitle('Controller modes: severity (colour), stick-slip boundary (cyan), '
                 'linear boundary (green, dashed)', fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown_table(maps: list[ControlMap]) -> str:
    """Lowest stick-slip-free surface speed per mode at each WOB of the grid."""
    wobs = maps[0].wobs_N
    head = '| mode | ' + ' | '.join(f'WOB {w / 1e3:g} kN' for w in wobs) + ' |'
    lines = [head, '|' + '---|' * (len(wobs) + 1)]
    for m in maps:
        cells = []
        for i in range(len(wobs)):
            v = m.lowest_stick_free_speed(i)
            cells.append('stick-slip at every speed' if v is None else f'{v:.1f} rad/s')
        lines.append(f'| {TITLES.get(m.mode, m.mode)} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines) + '\n'
