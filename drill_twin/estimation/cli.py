"""``drill-twin estimate``: the downhole estimator over a recording, and its study."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from ..console import print_summary
from ..errors import ParameterError

__all__ = ['register']

_BEGIN = '<!-- estimation table: begin (drill-twin estimate study) -->'
_END = '<!-- estimation table: end -->'


def cmd_estimate(args) -> int:
    if args.target == 'study':
        return _study(args)
    period = args.self_tuning_period
    if not (math.isfinite(period) and period >= 0):
        raise ParameterError(f'--self-tuning-period must be >= 0 s, got {period!r}')
    if args.set and not args.config:
        raise ParameterError('--set needs --config')
    from ..config.scenario import load_scenario, scenario_from_dict
    from ..io.mcap_reader import open_recording
    from .offline import estimate_recording, plot_estimate, recording_errors, recording_series
    rec = open_recording(args.target)
    if args.config:
        scenario, source = load_scenario(args.config, args.set or []), args.config
    elif 'scenario' in rec.run:
        source = f'{args.target}: its recorded configuration'
        scenario = scenario_from_dict(rec.run['scenario'], source)
    else:
        raise ParameterError(f'{args.target} does not say which string it recorded: give '
                             '--config (an SI finite-element configuration)')
    if not scenario.is_si or scenario.model.element_lengths_m is None:
        raise ParameterError(f'{source}: model {scenario.model.name} '
                             f"(units: {scenario.raw['units']}): the estimator needs an SI "
                             'finite-element string (units: si, model.type: fem)')
    series = recording_series(rec)
    from ..console import Progress
    est = estimate_recording(series, scenario, tune_every_s=args.self_tuning_period,
                             progress=Progress('estimating', sys.stderr.isatty()),
                             source=str(args.target))
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
    print_summary(json_safe(out) if args.json else out, args.json, width=22)
    return 0


def json_safe(value):
    """``value`` with every non-finite float (an F1 score of a run without sticks is NaN)
    replaced by None, in nested dicts and lists: JSON has no NaN (``null`` instead)."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _study(args) -> int:
    from .study import markdown_table, study_rows
    rows = study_rows(progress=(lambda line: None) if args.json else print)
    table = markdown_table(rows)
    out_dir = Path(args.out or 'docs')
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = json_safe(rows)
    (out_dir / 'estimation_study.json').write_text(json.dumps(rows, indent=1,
                                                              allow_nan=False) + '\n')
    doc = out_dir / 'estimation.md'
    if doc.exists() and _BEGIN in doc.read_text():
        text = doc.read_text()
        head, rest = text.split(_BEGIN, 1)
        tail = rest.split(_END, 1)[1]
        doc.write_text(f'{head}{_BEGIN}\n{table}\n{_END}{tail}')
    else:
        (out_dir / 'estimation_table.md').write_text(table + '\n')
    if args.json:
        print(json.dumps(rows, allow_nan=False))
    else:
        print(table)
    return 0


def register(sub):
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
