"""``drill-twin sweep``: a parameter sweep on Dask (docs/sweeps.md)."""
from __future__ import annotations

import json
import sys
import time
from dataclasses import replace
from pathlib import Path

from ..errors import ParameterError
from .spec import (
    DEFAULT_STATS,
    NONLINEAR_STATS,
    SweepSpec,
    parse_axis,
    parse_distribution,
    parse_stats,
)
from .store import SweepStore, stored_spec

__all__ = ['register', 'cmd_sweep', 'spec_from_args']

#: --threshold without the option [1/t*]
DEFAULT_THRESHOLD = 1e-9


def register(sub):
    s = sub.add_parser('sweep', help='parameter sweep on Dask: linear stability chart, '
                       'nonlinear stick-slip map, Monte Carlo (docs/sweeps.md)')
    s.add_argument('--config', required=True, help='YAML file, or a name in config/')
    s.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                   help='override a configuration value (dotted key), repeatable')
    s.add_argument('--x', required=True, help='axis KEY:MIN:MAX:N (dotted configuration key; '
                   'linear sweeps also upsilon_o)')
    s.add_argument('--y', help='second axis KEY:MIN:MAX:N')
    s.add_argument('--kind', choices=['linear', 'nonlinear'], default='linear')
    s.add_argument('--stat', action='append', default=None, metavar='NAME',
                   help=f"nonlinear statistic (repeatable; default {', '.join(DEFAULT_STATS)}; "
                   f"any of {', '.join(NONLINEAR_STATS)})")
    s.add_argument('--duration', type=float, default=None, help='nonlinear: simulated time per '
                   'point, in the configuration time unit (s for SI, t* otherwise)')
    s.add_argument('--settle', type=float, default=None, help='nonlinear: statistics from '
                   'this time on (default: half the duration)')
    s.add_argument('--samples', type=int, default=0, help='Monte Carlo samples per grid point')
    s.add_argument('--vary', action='append', default=[], metavar='KEY=DIST',
                   help='Monte Carlo: KEY=uniform(LOW,HIGH) | normal(MEAN,STD) | '
                   'lognormal(MEDIAN,SIGMA), repeatable')
    s.add_argument('--seed', type=int, default=None, help='Monte Carlo random seed '
                   '(default 0)')
    s.add_argument('--threshold', type=float, default=None, help='linear: real part above '
                   f'which a root counts as unstable [1/t*] (default {DEFAULT_THRESHOLD:g})')
    s.add_argument('--scheduler', default=None, help='Dask scheduler tcp://HOST:PORT (default: '
                   '$DASK_SCHEDULER_ADDRESS, else a local cluster; "inline": this process)')
    s.add_argument('--workers', type=int, default=None, help='local cluster: worker '
                   'processes (default: one per core)')
    s.add_argument('--block', type=int, default=None, help='points per task (default: about '
                   '0.5 s of work, timed on one point)')
    s.add_argument('--out', required=True, help='result directory (resumed if it holds the '
                   'same sweep): sweep.nc, sweep.png, blocks/')
    s.add_argument('--progress', action='store_true', help='progress bar even if stderr is '
                   'not a terminal')
    s.set_defaults(func=cmd_sweep)


def spec_from_args(args, block_points: int | None = None) -> SweepSpec:
    """The :class:`SweepSpec` of the command line, every part checked (``block_points``
    decided by the caller; None: the fewest allowed)."""
    from ..config.scenario import load_scenario
    _check_options(args)
    scenario = load_scenario(args.config, args.set)
    x = parse_axis(args.x, '--x')
    y = parse_axis(args.y, '--y') if args.y is not None else None
    vary = tuple(parse_distribution(v) for v in args.vary)
    duration = settle = 0.0
    if args.kind == 'nonlinear':
        if args.duration is None:
            raise ParameterError('a nonlinear sweep needs --duration (simulated time per point)')
        duration = args.duration
        settle = duration / 2 if args.settle is None else args.settle
    return SweepSpec(scenario.raw, args.kind, x, y, stats=parse_stats(args.stat, args.kind),
                     duration=duration, settle=settle, samples=args.samples, vary=vary,
                     seed=args.seed or 0, block_points=block_points, label=str(args.config),
                     threshold=DEFAULT_THRESHOLD if args.threshold is None else args.threshold)


#: options of one kind of sweep only: (option, attribute, the kind it belongs to)
_KIND_OPTIONS = (('--duration', 'duration', 'nonlinear'), ('--settle', 'settle', 'nonlinear'),
                 ('--threshold', 'threshold', 'linear'))


def _check_options(args) -> None:
    """Options that would be ignored are refused (an option of the other kind of sweep, a
    seed without samples); --block and --samples bounded below."""
    for option, name, kind in _KIND_OPTIONS:
        if getattr(args, name) is not None and args.kind != kind:
            raise ParameterError(f'{option} is an option of --kind {kind} sweeps (this one is '
                                 f'{args.kind})')
    if args.seed is not None and not args.samples:
        raise ParameterError(f'--seed {args.seed} seeds Monte Carlo draws: it needs --samples '
                             'N and --vary KEY=DIST')
    if args.block is not None and args.block < 1:
        raise ParameterError(f'--block {args.block}: must be >= 1 (points per task)')
    if args.samples < 0:
        raise ParameterError(f'--samples {args.samples}: must be >= 0')


def _timed_block_points(probe: SweepSpec, workers: int) -> int:
    """Points per block for about :data:`~drill_twin.sweep.engine.TARGET_TASK_S` of work,
    from the slowest of three points evaluated here."""
    from .engine import block_points_for
    from .evaluate import evaluate_points
    if probe.kind == 'nonlinear':
        from ..console import kernels_ready
        kernels_ready()
    print('drill-twin sweep: timing three points to size the blocks ...', file=sys.stderr,
          flush=True)
    middle = probe.points // 2
    evaluate_points(probe, range(middle, middle + 1))  # (a linear point's first call loads scipy)
    seconds = 0.0
    for flat in sorted({0, middle, probe.points - 1}):   # the slowest of three
        t0 = time.perf_counter()
        evaluate_points(probe, range(flat, flat + 1))
        seconds = max(seconds, time.perf_counter() - t0)
    return block_points_for(probe, seconds, workers)


def cmd_sweep(args) -> int:
    """Check everything, reach the scheduler, size the blocks, run, write the figure."""
    from ..console import Progress
    from .engine import check_executor, connect, run_sweep
    from .plot import plot_sweep
    address = check_executor(args.scheduler, args.workers)
    out = Path(args.out)
    spec = spec_from_args(args, args.block)
    stored = stored_spec(out)
    if stored is not None and args.block is None:
        spec = replace(spec, block_points=stored.block_points)
    SweepStore(out, spec)      # another sweep, or not a sweep directory: refused here
    with connect(address, args.workers) as executor:
        if stored is None and args.block is None:
            spec = replace(spec, block_points=_timed_block_points(spec, executor.workers))
        report = run_sweep(spec, out, executor=executor,
                           progress=Progress('sweep', args.progress or sys.stderr.isatty()))
    import xarray as xr
    with xr.open_dataset(out / 'sweep.nc', engine='scipy') as ds:
        plot_sweep(ds.load(), out / 'sweep.png', title=f'{spec.label}: {spec.kind} sweep')
    summary = report.as_dict()
    summary.update({'points': spec.points, 'blocks': spec.blocks, 'block_points':
                    spec.block_points, 'netcdf': str(out / 'sweep.nc'),
                    'figure': str(out / 'sweep.png')})
    print(json.dumps(summary))
    return 0
