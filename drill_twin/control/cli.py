"""``drill-twin control compare``: the controller modes side by side (docs/control.md)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__ = ['register']

#: statistics window of each run by default [s]
WINDOW_DEFAULT_S = 100.0
_BEGIN = '<!-- control table: begin (drill-twin control compare) -->'
_END = '<!-- control table: end -->'


def _grid(spec: str, name: str):
    try:
        lo, hi, n = spec.split(':')
        lo, hi, n = float(lo), float(hi), int(n)
    except ValueError:
        raise ParameterError(f'{name} must be MIN:MAX:N, got {spec!r}') from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi and 1 <= n <= 200):
        raise ParameterError(f'{name} must be 0 < MIN <= MAX and 1 <= N <= 200, got {spec!r}')
    return np.linspace(lo, hi, n)


def _check_wobs(config: str, wobs_N):
    """Every WOB of the grid must exceed what the wear flats carry alone (n_b λ W*): below
    it the bit does not cut (thesis eq. 2.3.6).  Said in kN, before any work."""
    from ..config.scenario import load_scenario
    sc = load_scenario(config)
    if not sc.is_si:
        raise ParameterError(f'control compare needs an SI configuration; {config} is not one')
    friction_N = sc.groups.n_b * sc.groups.lam * sc.scales.force_N
    low = float(np.min(wobs_N))
    if low <= friction_N:
        raise ParameterError(f'--wobs: {low / 1e3:g} kN does not exceed the {friction_N / 1e3:.4g}'
                             f' kN the wear flats of {config} carry alone (n_b λ W*): the bit '
                             'does not drill; start the grid above it')


def cmd_compare(args) -> int:
    import sys

    from ..console import Progress
    from .compare import compare_modes, markdown_table, plot_maps
    speeds = _grid(args.speeds, '--speeds')
    wobs = _grid(args.wobs, '--wobs') * 1e3
    if not (math.isfinite(args.duration_s) and math.isfinite(args.window_s)
            and args.duration_s > args.window_s > 0):
        raise ParameterError(f'need --duration-s > --window-s > 0 s, got --duration-s '
                             f'{args.duration_s:g} s and --window-s {args.window_s:g} s'
                             f'{" (the default)" if args.window_s == WINDOW_DEFAULT_S else ""}')
    _check_wobs(args.config, wobs)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from ..console import kernels_ready
    kernels_ready()
    print(f'drill-twin control compare: {len(speeds) * len(wobs)} operating points x 4 modes, '
          f'{args.duration_s:g} s simulated each', file=sys.stderr, flush=True)
    maps = compare_modes(args.config, speeds, wobs, args.duration_s, args.window_s,
                         workers=args.workers,
                         progress=Progress('control compare', sys.stderr.isatty()))
    figure = out / 'control_compare.png'
    plot_maps(maps, figure)
    table = markdown_table(maps)
    (out / 'control_compare.json').write_text(json.dumps([{
        'mode': m.mode, 'gains': m.gains, 'speeds_rad_s': m.speeds_rad_s.tolist(),
        'wobs_N': m.wobs_N.tolist(), 'abscissa_per_s': m.abscissa_per_s.tolist(),
        'severity': m.severity.tolist(), 'stick_fraction': m.stick_fraction.tolist()}
        for m in maps], indent=1))
    print(table, end='')
    if args.doc:
        doc = Path(args.doc)
        text = doc.read_text()
        if _BEGIN not in text or _END not in text:
            raise ParameterError(f'{doc} has no control table markers')
        head, rest = text.split(_BEGIN, 1)
        _, tail = rest.split(_END, 1)
        doc.write_text(head + _BEGIN + '\n' + table + _END + tail)
    return 0


def register(sub):
    s = sub.add_parser('control', help='top-drive controller modes (docs/control.md)')
    csub = s.add_subparsers(dest='action', required=True)
    c = csub.add_parser('compare', help='severity and spectral-abscissa maps of every mode '
                        'over surface speed x WOB, and the stick-slip-free speed table')
    c.add_argument('--config', default='benchmark_fem', help='SI finite-element configuration')
    c.add_argument('--speeds', default='4:24:6', help='surface speeds MIN:MAX:N [rad/s]')
    c.add_argument('--wobs', default='55:85:3', help='weights on bit MIN:MAX:N [kN]')
    c.add_argument('--duration-s', type=float, default=240.0, help='simulated time per point')
    c.add_argument('--window-s', type=float, default=WINDOW_DEFAULT_S,
                   help='statistics over the last WINDOW seconds')
    c.add_argument('--workers', type=int, default=None, help='processes (default: cores)')
    c.add_argument('--out', default='control_compare', help='directory of the figure and '
                   'JSON (docs/control.md: --out docs/figures --doc docs/control.md)')
    c.add_argument('--doc', default=None, help='write the table between the markers of '
                   'this Markdown file (docs/control.md)')
    c.set_defaults(func=cmd_compare)
