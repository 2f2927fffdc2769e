"""``drill-twin stability``: roots, critical speed, charts, discretisation, gallery and
variable pitch."""
from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..config.scenario import Scenario, load_scenario
from ..console import Progress, print_summary
from ..errors import ParameterError
from ..runtime.offline import positive


def cmd_stability(args) -> int:
    from .spectrum import critical_speed, rightmost_roots
    if args.action == 'variable-pitch':
        from .variable_pitch import plot_variable_pitch, variable_pitch_charts
        out = Path(args.out or 'variable_pitch.png')
        out.parent.mkdir(parents=True, exist_ok=True)
        n = (30, 20) if args.quick else (120, 80)
        results = variable_pitch_charts(n=n, workers=args.workers, progress=Progress(
            'variable pitch', sys.stderr.isatty()))
        plot_variable_pitch(results, out)
        numbers = {f'{d:g} deg': {k: v for k, v in r.items() if k != 'chart'}
                   for d, r in results.items()}
        out.with_suffix('.json').write_text(json.dumps(numbers, indent=1))
        print(json.dumps({'png': str(out), **numbers}, indent=None if args.json else 1))
        return 0
    if args.action == 'gallery':
        from .gallery import make_gallery
        summary = make_gallery(args.out or 'docs/figures', args.figure, quick=args.quick,
                               workers=args.workers,
                               progress=Progress('charts', sys.stderr.isatty()))
        print(json.dumps(summary, indent=1))
        return 0
    if args.config is None:
        raise ParameterError('--config is required')
    scenario = load_scenario(args.config, args.set)
    if args.action == 'chart':
        return _chart(args, scenario)
    if args.action == 'discretization':
        return _discretization(args, scenario)
    t_star = scenario.time_unit_s
    if args.action == 'roots':
        from .linearize import linearize_scenario
        if not 1 <= args.count <= 100:
            raise ParameterError(f'--count {args.count}: must be in [1, 100]')
        res = rightmost_roots(linearize_scenario(scenario), count=args.count)
        if scenario.is_si:   # SI in, SI out: rates in 1/s
            out = {'abscissa_1_s': res.abscissa / t_star,
                   'roots_1_s': [[z.real / t_star, z.imag / t_star] for z in res.roots],
                   'error_estimate_1_s': res.error_estimate / t_star, 'order': res.order}
        else:
            out = {'abscissa': res.abscissa, 'roots': [[z.real, z.imag] for z in res.roots],
                   'error_estimate': res.error_estimate, 'order': res.order}
    else:
        lo, hi = _omega_window(args, scenario)
        wc = critical_speed(scenario.model, scenario.groups, lo * t_star, hi * t_star)
        if scenario.is_si:
            out = {'critical_surface_speed_rad_s': wc / t_star if wc else None,
                   'searched_rad_s': [lo, hi]}
        else:
            out = {'critical_omega': wc, 'searched': [lo, hi]}
    print_summary(out, args.json, width=28)
    return 0


def _omega_window(args, scenario):
    """--omega-min/--omega-max in the configuration's units (rad/s for SI, 1/t* else)."""
    unit = 'rad/s' if scenario.is_si else '1/t*'
    lo = 0.5 if args.omega_min is None else args.omega_min
    hi = (60.0 if scenario.is_si else 50.0) if args.omega_max is None else args.omega_max
    for name, v in (('--omega-min', lo), ('--omega-max', hi)):
        positive(name, v, unit)
    if lo >= hi:
        raise ParameterError(f'--omega-min {lo:g} must be below --omega-max {hi:g} {unit}')
    return lo, hi


def _chart(args, scenario: Scenario) -> int:
    """``stability chart``: a linear sweep (:mod:`drill_twin.sweep`, its results kept in
    ``OUT.sweep/``), drawn and saved as before (PNG, and the chart data as .npz)."""
    from ..sweep import SweepSpec, SweepStore, parse_axis, run_sweep
    from ..sweep.engine import block_points_for, check_executor
    from .charts import ChartResult, plot_chart
    if not (args.x and args.y and args.out):
        raise ParameterError('stability chart needs --x, --y and --out')
    check_executor(args.scheduler, args.workers)    # before another chart's cache goes
    x, y = parse_axis(args.x, '--x'), parse_axis(args.y, '--y')
    if x.size < 2 or y.size < 2:
        raise ParameterError('a chart needs N >= 2 on both axes')
    spec = SweepSpec(scenario.raw, 'linear', x, y, threshold=args.threshold)
    spec = replace(spec, block_points=block_points_for(spec, CHART_POINT_S,
                                                       args.workers or os.cpu_count()))
    out = Path(args.out)
    _forget_other_sweep(out.with_suffix('.sweep'), spec)
    t0 = time.perf_counter()
    report = run_sweep(spec, out.with_suffix('.sweep'), workers=args.workers,
                       scheduler=args.scheduler, progress=Progress('chart',
                                                                   sys.stderr.isatty()))
    wall = time.perf_counter() - t0
    arrays = SweepStore(out.with_suffix('.sweep'), spec).arrays()
    chart = ChartResult(x.key, y.key, np.array(x.values), np.array(y.values),
                        arrays['abscissa'], arrays['unstable'])
    out.parent.mkdir(parents=True, exist_ok=True)
    plot_chart(chart, out, title=f'{scenario.model.name}: stable region shaded, D-curves')
    data = out.with_suffix('.npz')
    chart.save(data)
    stable = float((chart.unstable == 0).mean())
    print(json.dumps({'png': str(out), 'data': str(data), 'points': int(chart.unstable.size),
                      'stable_fraction': stable, 'wall_s': wall,
                      'sweep': report.as_dict()}))
    return 0


def _forget_other_sweep(directory: Path, spec) -> None:
    """A chart's sweep directory is its own cache: one of another chart is replaced (the
    same chart is resumed)."""
    import shutil

    from ..sweep.store import holds_other_sweep
    if holds_other_sweep(directory, spec):
        shutil.rmtree(directory)


#: typical cost of one linear chart point [s] (sizes the chart's tasks)
CHART_POINT_S = 1.5e-3


def _discretization(args, scenario: Scenario) -> int:
    from .discretization import chain_sequence, fem_sequence, plot_sequences
    if not scenario.is_si:
        raise ParameterError('the discretisation study needs an SI (FEM) configuration')
    sizes = [int(v) for v in args.sizes.split(',')]
    m = scenario.raw.get('model', {})
    damped = {'theta_u': m.get('theta_u', 5e-4), 'theta_phi': m.get('theta_phi', 1e-4)}
    series = {
        f"FEM, Rayleigh ϑ_u={damped['theta_u']:g}, ϑ_φ={damped['theta_phi']:g}":
            fem_sequence(scenario.system, scenario.groups, sizes, **damped),
        'FEM, undamped': fem_sequence(scenario.system, scenario.groups, sizes, theta_u=0.0,
                                      theta_phi=0.0),
        'FEM, undamped, imposed axial velocity': fem_sequence(
            scenario.system, scenario.groups, sizes, theta_u=0.0, theta_phi=0.0,
            axial_top='velocity'),
        'lumped chains (RGD-N, undamped)': chain_sequence(scenario.groups, scenario.kappa_d,
                                                          [1] + sizes),
    }
    table = {label: {str(n): [r[0].real, abs(r[0].imag)] for n, r in seq.items()}
             for label, seq in series.items()}
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        plot_sequences(series, args.out)
        table['png'] = args.out
    print(json.dumps(table, indent=None if args.json else 1))
    return 0


def register(sub):
    """Add ``stability`` to the ``drill-twin`` sub-parsers ``sub``."""
    s = sub.add_parser('stability', help='linear stability of the steady state')
    s.add_argument('action', choices=['roots', 'critical-speed', 'chart', 'discretization',
                                      'gallery', 'variable-pitch'])
    s.add_argument('--config', help='YAML file, or a name in config/')
    s.add_argument('--set', action='append', default=[], metavar='KEY=VALUE')
    s.add_argument('--figure', action='append', help='gallery: thesis figure id (repeatable)')
    s.add_argument('--quick', action='store_true', help='gallery: coarse grids (smoke test)')
    s.add_argument('--x', help='chart axis KEY:MIN:MAX:N (dotted config key or upsilon_o)')
    s.add_argument('--y', help='chart axis KEY:MIN:MAX:N')
    s.add_argument('--out', help='chart PNG (data goes beside it as .npz)')
    s.add_argument('--workers', type=int, default=None, help='processes (default: all cores)')
    s.add_argument('--scheduler', default=None, help='chart: Dask scheduler tcp://HOST:PORT '
                   '(as drill-twin sweep)')
    s.add_argument('--sizes', default='2,4,8,16,32,64,128,256',
                   help='discretization: element / oscillator counts')
    s.add_argument('--threshold', type=float, default=1e-9,
                   help='real part above which a root counts as unstable [1/t*]')
    s.add_argument('--json', action='store_true')
    s.add_argument('--count', type=int, default=6, help='number of rightmost roots')
    s.add_argument('--omega-min', type=float, default=None,
                   help='critical-speed search window: rad/s for SI configurations '
                   '(default 0.5), 1/t* for dimensionless ones (default 0.5)')
    s.add_argument('--omega-max', type=float, default=None,
                   help='rad/s for SI (default 60), 1/t* for dimensionless (default 50)')
    s.set_defaults(func=cmd_stability)
