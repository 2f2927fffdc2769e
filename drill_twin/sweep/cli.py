"""``drill-twin sweep``: a parameter sweep on Dask (docs/sweeps.md)."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..physics.parameters import ParameterError
from .spec import DEFAULT_STATS, NONLINEAR_STATS, SweepSpec, parse_axis, parse_distribution
from .store import stored_spec

__all__ = ['add_parsers', 'cmd_sweep', 'spec_from_args']


def add_parsers(sub):
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
    s.add_argument('--seed', type=int, default=0, help='Monte Carlo random seed')
    s.add_argument('--threshold', type=float, default=1e-9,
                   help='linear: real part above which a root counts as unstable [1/t*]')
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


def spec_from_args(args, block_points: int = 1) -> SweepSpec:
    """The :class:`SweepSpec` of the command line (``block_points`` decided by the caller)."""
    from ..physics.scenario import load_scenario
    scenario = load_scenario(args.config, args.set)
    x = parse_axis(args.x)
    y = parse_axis(args.y) if args.y else None
    vary = tuple(parse_distribution(v) for v in args.vary)
    duration = settle = 0.0
    if args.kind == 'nonlinear':
        if args.duration is None:
            raise ParameterError('a nonlinear sweep needs --duration (simulated time per point)')
        duration = args.duration
        settle = duration / 2 if args.settle is None else args.settle
        if 'upsilon_o' in {x.key, y.key if y else None}:
            raise ParameterError('upsilon_o is an axis of linear sweeps only: sweep '
                                 'operating_point.weight_on_bit_N or groups.W_o instead')
    return SweepSpec(scenario.raw, args.kind, x, y, stats=tuple(args.stat or DEFAULT_STATS),
                     duration=duration, settle=settle, samples=args.samples, vary=vary,
                     seed=args.seed, threshold=args.threshold, block_points=block_points,
                     label=str(args.config))


def _block_points(args, out: Path) -> int:
    """``--block``, else the block size of the sweep being resumed, else timed."""
    from .engine import block_points_for
    from .evaluate import evaluate_block
    if args.block is not None:
        return args.block
    stored = stored_spec(out)
    if stored is not None:
        return int(stored['block_points'])
    probe = spec_from_args(args, 1)
    if probe.kind == 'nonlinear':
        from ..console import kernels_ready
        kernels_ready()
    print('drill-twin sweep: timing three points to size the blocks ...', file=sys.stderr,
          flush=True)
    evaluate_block(probe, probe.points // 2)   # (a linear point's first call loads scipy)
    seconds = 0.0
    for flat in sorted({0, probe.points // 2, probe.points - 1}):   # the slowest of three
        t0 = time.perf_counter()
        evaluate_block(probe, flat)
        seconds = max(seconds, time.perf_counter() - t0)
    import os
    return block_points_for(probe, seconds, args.workers or os.cpu_count())


def cmd_sweep(args) -> int:
    from ..console import Progress
    from .engine import run_sweep
    from .plot import plot_sweep
    if (args.workers is not None and args.workers < 1) or (args.block is not None
                                                           and args.block < 1):
        raise ParameterError('--workers and --block must be >= 1')
    out = Path(args.out)
    spec = spec_from_args(args, _block_points(args, out))
    report = run_sweep(spec, out, scheduler=args.scheduler, workers=args.workers,
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
