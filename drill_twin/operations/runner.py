"""Run a scenario file offline on the twin, record it, draw it (``drill-twin scenario``).

The run is what the twin node does with the same file: ticks at ``rate_hz``, the
driller sets the set-points at each tick, the twin advances to the next tick and
its measurements are taken.  With an output path the run is recorded by the
twin's own recorder (set-points as applied, measurements per tick, simulated
time), so ``drill-twin replay --resimulate`` reproduces it.
"""
from __future__ import annotations

import numpy as np

from ..config.scenario import load_scenario
from ..runtime.digital_twin import DigitalTwin
from ..runtime.session import TickSession
from .timeline import load_timeline

__all__ = ['run_timeline', 'plot_operations', 'SERIES']

#: series kept for the figure and the summary (measurement keys)
SERIES = ('surface_speed_rad_s', 'bit_angular_speed_rad_s', 'weight_on_bit_N', 'hook_load_N',
          'torque_on_bit_Nm', 'surface_torque_Nm', 'bit_above_bottom_m', 'bit_depth_m',
          'rate_of_penetration_m_s', 'block_velocity_setpoint_m_s')


def build_twin(timeline) -> DigitalTwin:
    """The twin of a timeline: its configuration and overrides, at rest or drilling, with
    the integration step aligned to the ticks as in the node (a tick is a whole number of
    steps)."""
    scenario = load_scenario(timeline.configuration, list(timeline.overrides),
                             label=f'{timeline.path} overrides:')
    gap = timeline.bit_above_bottom_m if timeline.start == 'rest' else None
    return TickSession.aligned_twin(scenario, timeline.rate_hz, start_above_bottom_m=gap)


def run_timeline(path_or_timeline, out=None, progress=None, chunk_period_s: float = 0.25,
                 observe=None):
    """Run a scenario file; returns ``{'time_s', series..., 'log': [(t, label)], 'twin'}``.

    ``out``: record the run to this ``.mcap`` file (the 3-D view included).
    ``progress(label)`` is called when a step starts; ``observe(session)`` with the
    :class:`~drill_twin.runtime.session.TickSession` before the first set-point (the live
    view attaches its listeners there).
    """
    timeline = path_or_timeline if hasattr(path_or_timeline, 'steps') else \
        load_timeline(path_or_timeline)
    twin = build_twin(timeline)
    recorder = None
    if out is not None:
        from ..io.run_recorder import TwinRecorder
        recorder = TwinRecorder(out, twin, timeline.configuration, timeline.overrides,
                                settings={'publish_rate_hz': timeline.rate_hz,
                                          'scenario': str(timeline.path),
                                          'source': 'drill-twin scenario run'},
                                chunk_period_s=chunk_period_s)
    session = TickSession(twin, timeline.rate_hz, recorder)
    rows = {k: [] for k in ('time_s',) + SERIES}
    try:
        if observe is not None:
            observe(session)
        if recorder is not None:  # the set-points in force at the start, as applied
            session.record_scene()
            session.apply_initial_setpoints()
        session.start_scenario(timeline)
        driller, shown = session.driller, 0
        while not driller.done:
            if progress is not None and len(driller.log) > shown:
                shown = len(driller.log)
                progress(driller.log[-1][1])
            m = session.tick()
            for key in rows:
                rows[key].append(m[key])
    finally:
        session.close()
    out_series = {key: np.asarray(v) for key, v in rows.items()}
    out_series['log'] = driller.log
    out_series['twin'] = twin
    out_series['timeline'] = timeline
    return out_series


def plot_operations(series: dict, path, title: str = ''):
    """Surface and bit speed, WOB and hook load, torques, bit height above the rock, with
    the steps of the timeline marked."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    t = series['time_s']
    fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True)
    ax = axes[0]
    ax.plot(t, series['surface_speed_rad_s'] * 60 / (2 * np.pi), label='surface (rpm)')
    ax.plot(t, series['bit_angular_speed_rad_s'] * 60 / (2 * np.pi), lw=0.7,
            label='bit (rpm)')
    ax.set_ylabel('speed [rpm]')
    ax.legend(loc='upper left', fontsize=8)
    ax = axes[1]
    ax.plot(t, series['weight_on_bit_N'] / 1e3, lw=0.7, label='WOB (bit)')
    ax.plot(t, (series['twin'].string_weight_N - series['hook_load_N']) / 1e3, lw=0.9,
            label='weight − hook load (what the rig sees)')
    ax.set_ylabel('force [kN]')
    ax.legend(loc='upper left', fontsize=8)
    ax = axes[2]
    ax.plot(t, series['surface_torque_Nm'] / 1e3, label='surface torque')
    ax.plot(t, series['torque_on_bit_Nm'] / 1e3, lw=0.7, label='torque on bit')
    ax.set_ylabel('torque [kN m]')
    ax.legend(loc='upper left', fontsize=8)
    ax = axes[3]
    ax.plot(t, series['bit_above_bottom_m'], label='bit above bottom [m]')
    ax.set_ylabel('height [m]')
    ax.set_xlabel('time [s]')
    ax2 = ax.twinx()
    ax2.plot(t, series['rate_of_penetration_m_s'] * 3600, color='tab:green', lw=0.6)
    ax2.set_ylabel('bit axial speed [m/h]', color='tab:green')
    for t0, label in series['log']:
        for a in axes:
            a.axvline(t0, color='0.6', lw=0.6, ls=':')
        axes[0].annotate(label.split(' (')[0], (t0, 1.0), xycoords=('data', 'axes fraction'),
                         rotation=90, va='top', ha='right', fontsize=7, color='0.3')
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
