"""``drill-twin scenario ...``: run, list and draw the operations scenarios."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..console import kernels_ready, print_summary
from ..errors import ParameterError

__all__ = ['register']


def _summary(series) -> dict:
    """Numbers of a run: the last 20 % of its final step (drilling statistics there)."""
    import numpy as np
    t = series['time_s']
    t_last = series['log'][-1][0]
    w = t >= t_last + 0.8 * (t[-1] - t_last)
    rpm = series['bit_angular_speed_rad_s'][w] * 60 / (2 * np.pi)
    return {'simulated_s': float(t[-1]), 'steps': len(series['log']),
            'final_bit_rpm_mean': float(rpm.mean()), 'final_bit_rpm_min': float(rpm.min()),
            'final_bit_rpm_max': float(rpm.max()),
            'final_wob_N_mean': float(series['weight_on_bit_N'][w].mean()),
            'final_rop_m_h_mean': float(series['rate_of_penetration_m_s'][w].mean() * 3600),
            'events': int(series['twin'].sim.event_count)}


def cmd_scenario(args) -> int:
    from .runner import plot_operations, run_timeline
    from .timeline import load_timeline, shipped_scenarios
    if args.action == 'list':
        shipped = shipped_scenarios()
        if not shipped:
            raise ParameterError('no shipped scenario files found (config/operations of the '
                                 'source tree or share/drill_twin/config/operations)')
        for path in shipped.values():
            timeline = load_timeline(path)
            print(f'{path.stem:>20}: {timeline.description} ({len(timeline.steps)} steps)')
        return 0
    if args.action == 'run':
        if not args.file:
            raise ParameterError('scenario run needs a scenario file (or a shipped name: '
                                 '`drill-twin scenario list`)')
        timeline = load_timeline(args.file)
        kernels_ready()
        view = feed = None
        if args.live is not None:
            from ..live.run import PacedFeed, live_topics
            from ..live.server import LiveView
            view = LiveView(live_topics(), args.live)
            feed = PacedFeed(view)
            print(f'drill-twin: live view on {view.url} (Foxglove: Open connection, Foxglove '
                  'WebSocket); the scenario runs in real time', file=sys.stderr)
        t0 = time.perf_counter()
        try:
            series = run_timeline(timeline, out=args.out,
                                  observe=feed.attach if feed is not None else None)
        finally:
            if view is not None:
                view.close()
        out = _summary(series)
        out['wall_s'] = time.perf_counter() - t0
        if args.out:
            out['recording'] = str(args.out)
        if args.plot:
            Path(args.plot).parent.mkdir(parents=True, exist_ok=True)
            plot_operations(series, args.plot, timeline.description or str(args.file))
            out['plot'] = str(args.plot)
        if not args.json:
            for t, label in series['log']:
                print(f'{t:9.2f} s  {label}')
        print_summary(out, args.json, width=20)
        return 0
    # figures: every shipped scenario, its figure and numbers (docs/operations.md)
    out_dir = Path(args.out or 'docs/figures')
    out_dir.mkdir(parents=True, exist_ok=True)
    kernels_ready()
    numbers = {}
    for path in shipped_scenarios().values():
        timeline = load_timeline(path)
        series = run_timeline(timeline)
        png = out_dir / f'operations_{path.stem}.png'
        plot_operations(series, png, timeline.description)
        numbers[path.stem] = {**_summary(series), 'png': png.name,
                              'log': [[round(t, 2), label] for t, label in series['log']]}
        print(f'{path.stem}: {png}')
    (out_dir / 'operations.json').write_text(json.dumps(numbers, indent=1))
    return 0


def register(sub):
    s = sub.add_parser('scenario', help='operations: run a scenario file (timeline of rig '
                       'operations), list the shipped ones, or draw them all')
    s.add_argument('action', choices=['run', 'list', 'figures'])
    s.add_argument('file', nargs='?', help='run: scenario file, or a name in config/operations')
    s.add_argument('--out', help='run: record to this .mcap file; figures: output directory')
    s.add_argument('--plot', help='run: draw the run to this PNG')
    s.add_argument('--json', action='store_true')
    from ..runtime.cli import add_live_argument
    add_live_argument(s)
    s.set_defaults(func=cmd_scenario)
