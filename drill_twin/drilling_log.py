"""The driller's log of a recording: time-based tracks as on a rig's electronic drilling
recorder (``drill-twin mcap plot --log RUN.mcap``).

Tracks, side by side, time (or drilled depth) running down the page as on a paper log:

1. hook load and WOB [kN];
2. surface (top-drive) RPM and bit RPM [rpm];
3. surface torque and torque on bit (TOB) [kN m];
4. ROP [m/h];
5. stick-slip severity [-], the stick phases (the bit stuck) shaded on every track.

Written to PNG (matplotlib) and to one self-contained interactive HTML page (Plotly, its
JavaScript embedded: it opens without a network).  Depth axis: the bit's displacement
since the start of the recording [m] (``joint_states``' ``bit_axial`` position), for runs
that drill.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ['log_series', 'plot_log_png', 'plot_log_html', 'TRACKS', 'write_log']

RPM = 60.0 / (2.0 * math.pi)
#: (track title, [(series key, label, scale from SI, colour)])
TRACKS = (
    ('Hook load & WOB [kN]', [('hook_load_N', 'hook load', 1e-3, '#1f77b4'),
                              ('weight_on_bit_N', 'WOB', 1e-3, '#d62728')]),
    ('RPM', [('surface_speed_rad_s', 'surface RPM', RPM, '#2ca02c'),
             ('bit_speed_rad_s', 'bit RPM', RPM, '#9467bd')]),
    ('Torque [kN m]', [('surface_torque_Nm', 'surface torque', 1e-3, '#ff7f0e'),
                       ('torque_on_bit_Nm', 'TOB', 1e-3, '#8c564b')]),
    ('ROP [m/h]', [('rate_of_penetration_m_s', 'ROP', 3600.0, '#17becf')]),
    ('Stick-slip severity [-]', [('stick_slip_severity', 'severity', 1.0, '#e377c2')]),
)
#: series key: (topic, field) in the twin's interface
_SOURCES = {
    'hook_load_N': ('surface/hook_load', 'data'),
    'weight_on_bit_N': ('bit/wrench', 'wrench.force.x'),
    'surface_speed_rad_s': ('surface/top_drive_speed', 'data'),
    'bit_speed_rad_s': ('bit/velocity', 'twist.angular.x'),
    'surface_torque_Nm': ('surface/torque', 'data'),
    'torque_on_bit_Nm': ('bit/wrench', 'wrench.torque.x'),
    'rate_of_penetration_m_s': ('bit/rate_of_penetration', 'data'),
    'stick_slip_severity': ('bit/stick_slip_severity', 'data'),
    'stuck': ('bit/stuck', 'data'),
    'bit_displacement_m': ('joint_states', 'position'),
}


def log_series(recording) -> dict:
    """``{'time_s', series...}`` of the log's channels from a recording (one sample per
    tick; a channel the recording lacks is left out)."""
    from .io.export import field_value
    ns = recording.run.get('namespace', '/').rstrip('/')
    by_topic = {}
    for key, (topic, fld) in _SOURCES.items():
        by_topic.setdefault(f'{ns}/{topic}', []).append((key, fld))
    present = [topic for topic in by_topic if topic in recording.topics]
    times = {topic: [] for topic in present}
    cols = {topic: {k: [] for k, _ in by_topic[topic]} for topic in present}
    for topic, t_ns, msg in recording.decoded(present):    # one pass over the file
        times[topic].append(t_ns * 1e-9)
        for key, fld in by_topic[topic]:
            value = field_value(msg, fld)
            cols[topic][key].append(float(value[3]) if key == 'bit_displacement_m'
                                    else float(value))
    out = {}
    for topic in present:
        out.setdefault('time_s', np.asarray(times[topic]))
        for key, values in cols[topic].items():
            if len(values) == len(out['time_s']):
                out[key] = np.asarray(values)
    if 'time_s' not in out:
        raise ValueError('none of the twin measurement topics')
    if 'bit_displacement_m' in out:
        displacement = out.pop('bit_displacement_m')
        out['drilled_m'] = displacement - displacement[0]
    return out


def _stick_spans(t, stuck):
    edges = np.flatnonzero(np.diff(np.concatenate([[0], stuck.astype(int), [0]])))
    return [(t[a], t[min(b, len(t) - 1)]) for a, b in zip(edges[::2], edges[1::2])]


def _axis(series, depth: bool):
    if depth:
        if 'drilled_m' not in series:
            raise ValueError('no depth channel (joint_states) for a depth axis')
        return series['drilled_m'], 'drilled depth [m]'
    return series['time_s'], 'time [s]'


def plot_log_png(series: dict, path, title: str = '', depth: bool = False):
    """The log as a PNG (tracks side by side, the index axis running down)."""
    from .plotting import plt
    y, ylabel = _axis(series, depth)
    spans = _stick_spans(y, series['stuck'] > 0.5) if 'stuck' in series else []
    fig, axes = plt.subplots(1, len(TRACKS), figsize=(2.6 * len(TRACKS), 9), sharey=True)
    for ax, (name, curves) in zip(axes, TRACKS):
        for key, label, scale, colour in curves:
            if key in series:
                ax.plot(series[key] * scale, y, lw=0.7, color=colour, label=label)
        for a, b in spans:
            ax.axhspan(a, b, color='tab:red', alpha=0.15, lw=0)
        ax.set_title(name, fontsize=9)
        ax.grid(True, lw=0.3)
        ax.xaxis.tick_top()
        ax.legend(loc='lower right', fontsize=7)
    axes[0].set_ylabel(ylabel)
    axes[0].invert_yaxis()
    fig.suptitle((title + ' — ' if title else '') + 'driller\'s log (stick phases shaded)',
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_log_html(series: dict, path, title: str = '', depth: bool = False):
    """The log as one self-contained interactive HTML page (Plotly's JavaScript inline)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots
    y, ylabel = _axis(series, depth)
    fig = make_subplots(rows=1, cols=len(TRACKS), shared_yaxes=True,
                        subplot_titles=[name for name, _ in TRACKS], horizontal_spacing=0.02)
    for col, (name, curves) in enumerate(TRACKS, start=1):
        for key, label, scale, colour in curves:
            if key in series:
                fig.add_trace(go.Scattergl(x=series[key] * scale, y=y, name=label,
                                           mode='lines', line={'color': colour, 'width': 1},
                                           legendgroup=name), row=1, col=col)
    if 'stuck' in series:
        for a, b in _stick_spans(y, series['stuck'] > 0.5):
            fig.add_hrect(y0=a, y1=b, fillcolor='red', opacity=0.15, line_width=0)
    fig.update_yaxes(autorange='reversed', title_text=ylabel, row=1, col=1)
    fig.update_xaxes(side='top')
    fig.update_layout(title=(title + ' — ' if title else '') + "driller's log",
                      height=900, template='plotly_white', legend={'orientation': 'h'})
    fig.write_html(str(path), include_plotlyjs=True, full_html=True)


def write_log(recording, out, title: str = '', depth: bool = False) -> dict:
    """The log of ``recording`` to ``out`` (``.png`` or ``.html``; any other suffix: both,
    beside each other).  Returns ``{'png'/'html': path, 'samples': n}``."""
    series = log_series(recording)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    written = {}
    kinds = [out.suffix.lstrip('.')] if out.suffix in ('.png', '.html') else ['png', 'html']
    for kind in kinds:
        path = out if out.suffix == f'.{kind}' else out.with_suffix(f'.{kind}')
        (plot_log_png if kind == 'png' else plot_log_html)(series, path, title, depth)
        written[kind] = str(path)
    written['samples'] = len(series['time_s'])
    return written
