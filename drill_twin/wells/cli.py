"""``drill-twin well``: torque and drag of a configuration's string in its well."""
from __future__ import annotations

import json
import math
from pathlib import Path

from ..config.cli import add_config_arguments
from ..config.scenario import load_scenario
from ..errors import ParameterError

__all__ = ['register']


def _factors(text: str) -> list:
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError:
        values = []
    if not values or len(values) > 12 or not all(math.isfinite(v) and 0 <= v <= 2
                                                  for v in values):
        raise ParameterError(f'--friction {text!r}: 1 to 12 friction factors in [0, 2], '
                             'comma-separated (e.g. 0.1,0.2,0.3,0.4)')
    return values


def cmd_well(args) -> int:
    from .torque_drag_charts import plot_broomstick, plot_profile, well_charts
    scenario = load_scenario(args.config, args.set)
    result = well_charts(scenario, _factors(args.friction), args.depths)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plot_broomstick(result['chart'], out / 'broomstick.png')
    plot_profile(result, out / 'torque_profile.png')
    chart, off, on = result['chart'], result['off_bottom'], result['on_bottom']
    summary = {
        'friction_factors': chart.friction_factor.tolist(),
        'bit_depth_m': float(chart.bit_depth_m[-1]),
        'pick_up_hook_load_N': chart.pick_up_N[:, -1].tolist(),
        'slack_off_hook_load_N': chart.slack_off_N[:, -1].tolist(),
        'rotating_hook_load_N': float(chart.rotating_N[0, -1]),
        'friction_factor': result['friction_factor'],
        'surface_torque_off_bottom_Nm': off.surface_torque_Nm,
        'surface_torque_on_bottom_Nm': on.surface_torque_Nm,
        'hook_load_on_bottom_N': on.hook_load_N,
        'weight_on_bit_N': result['weight_on_bit_N'],
        'pngs': [str(out / 'broomstick.png'), str(out / 'torque_profile.png')]}
    (out / 'well.json').write_text(json.dumps(summary, indent=1))
    print(json.dumps(summary, indent=None if args.json else 1))
    return 0


def register(sub):
    """Add ``well`` to the ``drill-twin`` sub-parsers ``sub``."""
    s = sub.add_parser('well', help='torque and drag on the well path: the hook-load '
                       'broomstick and the torque profile (docs/torque_drag.md)')
    add_config_arguments(s)
    s.add_argument('--friction', default='0.1,0.2,0.3,0.4',
                   help='broomstick friction factors, comma-separated')
    s.add_argument('--depths', type=int, default=40, help='bit depths of the broomstick')
    s.add_argument('--out', default='well', help='output directory (PNGs and well.json)')
    s.add_argument('--json', action='store_true', help='one-line JSON')
    s.set_defaults(func=cmd_well)
