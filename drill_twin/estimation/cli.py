"""``drill-twin estimate``: the downhole estimator over a recording, and its study."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from ..console import print_summary
from ..physics.parameters import ParameterError

__all__ = ['add_parsers']

_BEGIN = '<!-- estimation table: begin (drill-twin estimate study) -->'
_END = '<!-- estimation table: end -->'


def cmd_estimate(args) -> int:
    import math
    if args.target == 'study':
        return _study(args)
    period = args.self_tuning_period
    if not (math.isfinite(period) and period >= 0):
        raise ParameterError(f'--self-tuning-period must be >= 0 s, got {period!r}')
    if args.set and not args.config:
        raise ParameterError('--set needs --config')
    from ..io.mcap_reader import open_recording
    from ..physics.scenario import load_scenario, scenario_from_dict
    from .offline import estimate_recording, plot_estimate, recording_errors, recording_series
    rec = open_recording(args.target)
    if args.config:
        scenario = load_scenario(args.config, args.set or [])
    elif 'scenario' in rec.run:
        scenario = scenario_from_dict(rec.run['scenario'])
    else:
        raise ParameterError(f'{args.target} does not say which string it recorded: give '
                             '--config (an SI finite-element configuration)')
    series = recording_series(rec)
    from ..console import Progress
    est = estimate_recording(series, scenario, tune_every_s=args.self_tuning_period,
                             progress=Progress('estimating', sys.stderr.isatty()))
    out = {'recording': str(args.target), 'samples': int(est['time_s'].size),
           'rate_hz': est['rate_hz']}
    if est['rejected']:
        out['refused_samples'] = est['rejected']
        print(f'drill-twin: warning: refused corrupt surface samples {est["rejected"]} '
              '(non-finite or beyond any rig; the last acceptable value was held)',
              file=sys.stderr)
    errors = recording_errors(series, est)
    if errors is not None:
        out['errors'] = errors
    if est['fits']:
        last = est['fits'][-1][1]
        out['self_tuning'] = {'fits': len(est['fits']), **last.as_dict()}
    if args.out:
        out_dir = Path(args.out)
        out_dir.mkdir(parents=True, exist_ok=True)
        png = out_dir / (Path(args.target).stem + '_estimate.png')
        plot_estimate(series, est, png, title=f'{Path(args.target).name}: surface-based '
                      'estimate of the bit')
        out['plot'] = str(png)
    print_summary(out, args.json, width=22)
    return 0


def _study(args) -> int:
    from .study import markdown_table, study_rows
    rows = study_rows(progress=(lambda line: None) if args.json else print)
    table = markdown_table(rows)
    out_dir = Path(args.out or 'docs')
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / 'estimation_study.json').write_text(json.dumps(rows, indent=1) + '\n')
    doc = out_dir / 'estimation.md'
    if doc.exists() and _BEGIN in doc.read_text():
        text = doc.read_text()
        head, rest = text.split(_BEGIN, 1)
        tail = rest.split(_END, 1)[1]
        doc.write_text(f'{head}{_BEGIN}\n{table}\n{_END}{tail}')
    else:
        (out_dir / 'estimation_table.md').write_text(table + '\n')
    if args.json:
        print(json.dumps(rows))
    else:
        print(table)
    return 0


def add_parsers(sub):
    s = sub.add_parser('estimate', help='estimate the bit from a recording\'s surface topics '
                       '(or `estimate study`: the table of docs/estimation.md)')
    s.add_argument('target', help='RUN.mcap, or "study"')
    s.add_argument('--out', help='directory for the plot (study: for estimation.md and '
                   'estimation_study.json, default docs)')
    s.add_argument('--config', help='the string model (default: the one the recording names)')
    s.add_argument('--set', action='append', metavar='KEY=VALUE',
                   help='override a configuration value (with --config)')
    s.add_argument('--self-tuning-period', type=float, default=120.0, metavar='S',
                   help='self-tune every S seconds of data (0 = off)')
    s.add_argument('--json', action='store_true')
    s.set_defaults(func=cmd_estimate)
