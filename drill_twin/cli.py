"""``drill-twin``: the offline command-line tool.

Sub-commands
------------
``simulate``   run a configuration, write the time series (npz), print a summary
``config``     the configuration schema (every key, unit, range), or check a file
``params``     print the SI scales and every derived dimensionless group
``stability``  characteristic roots / critical speed of the linearised model
``demo``       the main job of ``make demo``: the benchmark run(s) with outputs
``reproduce``  regenerate the thesis's computable figures (docs/reproduction.md)
``scenario``   run a timeline of rig operations (connection, start-up ...), draw them
``mcap``       inspect / recover / export / plot a recording
``replay``     republish a recording with its timing, or resimulate it
"""
from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .console import Progress, kernels_ready, print_summary
from .control.cli import add_parsers as add_control_parsers
from .estimation.cli import add_parsers as add_estimation_parsers
from .io.mcap_reader import RecordingError
from .operations.cli import add_parsers as add_operations_parsers
from .physics.digital_twin import SetpointError
from .physics.parameters import ParameterError
from .physics.scenario import Scenario, load_scenario
from .physics.simulation import Simulation, SimulationDiverged
from .physics.statistics import SERIES_UNITS, output_series, stick_slip_summary
from .recording_cli import add_parsers as add_recording_parsers
from .sweep.cli import add_parsers as add_sweep_parsers


def run_scenario(scenario: Scenario, duration=None, progress=None):
    """Run a scenario; return (series in config units, wall seconds, simulation)."""
    sim = Simulation.from_scenario(scenario)
    t0 = time.perf_counter()
    traj = sim.run(duration or scenario.duration, scenario.record_interval, progress=progress)
    wall = time.perf_counter() - t0
    return output_series(scenario, traj), wall, sim


#: most recorded rows one ``simulate`` keeps in memory (17 channels: 2.3 GB)
MAX_RECORDED_ROWS = 20_000_000


def _positive(name, value, unit):
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(f'{name} {value:g} {unit}: must be a finite number > 0')
    return value


def _duration(args, scenario: Scenario):
    """The run length in t*, from --duration [s] or --tau [t*] (checked in the unit the
    user gave), or the configuration's."""
    if args.duration is not None and args.tau is not None:
        raise ParameterError('give --duration (seconds) or --tau (units of t*), not both')
    if args.duration is not None and not scenario.is_si:
        raise ParameterError('--duration is in seconds, for SI configurations; this one is '
                             'dimensionless: use --tau (units of t*)')
    if args.tau is not None:
        duration = _positive('--tau', args.tau, 't*')
    elif args.duration is not None:
        duration = _positive('--duration', args.duration, 's') / scenario.time_unit_s
    else:
        duration = scenario.duration
    rows = duration / scenario.record_interval
    if rows > MAX_RECORDED_ROWS:
        unit = 's' if scenario.is_si else 't*'
        raise ParameterError(
            f'{duration * scenario.time_unit_s:g} {unit} recorded every '
            f'{scenario.record_interval * scenario.time_unit_s:g} {unit} is {rows:.3g} rows '
            f'(more than {MAX_RECORDED_ROWS:.0e}): raise simulation.record_interval'
            f'{"_s" if scenario.is_si else ""}')
    return duration


def cmd_simulate(args) -> int:
    scenario = load_scenario(args.config, args.set)
    duration = _duration(args, scenario)
    if not (math.isfinite(args.stats_from) and args.stats_from >= 0):
        raise ParameterError(f'--stats-from {args.stats_from:g}: must be >= 0')
    if args.stats_from >= duration * scenario.time_unit_s:
        raise ParameterError(f'--stats-from {args.stats_from:g} is not before the end of the '
                             f'run ({duration * scenario.time_unit_s:g} '
                             f'{"s" if scenario.is_si else "t*"})')
    if not (math.isfinite(args.rate_hz) and 0 < args.rate_hz <= 10000):
        raise ParameterError(f'--rate-hz {args.rate_hz:g}: must be in (0, 10000] Hz')
    kernels_ready()
    progress = Progress('simulating', sys.stderr.isatty() and not args.summary_json)
    if args.out and args.out.endswith('.mcap'):
        return _simulate_to_mcap(args, scenario, duration, progress)
    series, wall, sim = run_scenario(scenario, duration, progress)
    summary = stick_slip_summary(series, args.stats_from or 0.0)
    summary.update({'model': scenario.model.name,
                    'integrated_model': scenario.integrated_model.name,
                    'time_step_tstar': scenario.time_step,
                    'units': 'si' if scenario.is_si else
                    'dimensionless', 'simulated': float(series['time'][-1]),
                    'wall_s': wall, 'events': sim.event_count,
                    'history_overflows': sim.history_overflows})
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out, **series, units=json.dumps(
            {k: v[0 if scenario.is_si else 1] for k, v in SERIES_UNITS.items()}))
        summary['output'] = str(out)
    print_summary(summary, args.summary_json)
    return 0


def _simulate_to_mcap(args, scenario: Scenario, duration, progress) -> int:
    """The run as the twin node would publish it, recorded (simulated log time)."""
    from .io.run_recorder import record_run
    if not scenario.is_si:
        raise ParameterError('MCAP recording needs an SI configuration (the twin publishes SI)')
    stop = threading.Event()  # SIGINT/SIGTERM end the run between ticks; the file is closed
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    t0 = time.perf_counter()
    try:
        out = record_run(scenario, args.out, duration * scenario.time_unit_s, args.rate_hz,
                         config=args.config, overrides=args.set, progress=progress,
                         stop=stop.is_set)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    out['wall_s'] = time.perf_counter() - t0
    if out['stopped']:
        print(f"drill-twin: interrupted at {out['simulated_s']:.3f} s simulated; "
              f"{out['path']} is complete", file=sys.stderr)
        return 130
    print_summary(out, args.summary_json)
    return 0


def cmd_config(args) -> int:
    """``config schema``: the configuration keys as Markdown; ``config check``: validate a
    configuration with its overrides and print it resolved (YAML)."""
    if args.action == 'schema':
        from .physics.schema import schema_markdown
        print(schema_markdown(), end='')
        return 0
    if not args.config:
        raise ParameterError('config check needs --config FILE')
    import yaml
    scenario = load_scenario(args.config, args.set)
    print(yaml.safe_dump(scenario.raw, sort_keys=False), end='')
    return 0


#: field units: pound-force [N], foot [m], foot-pound-force [N m], pounds per US gallon
#: [kg/m^3]
LBF, FT, FT_LBF, PPG = 4.4482216152605, 0.3048, 1.3558179483314, 119.826427


def cmd_params(args) -> int:
    scenario = load_scenario(args.config, args.set)
    g = scenario.groups
    out = {'n_b': g.n_b, 'lambda': g.lam, 'n_b_lambda': g.n_b * g.lam, 'beta': g.beta,
           'psi': g.psi, 'W_o': g.W_o, 'omega_o': g.omega_o, 'upsilon_o': g.upsilon_o,
           'delta_o': g.delta_o, 'T_o': g.T_o, 'tau_10': g.tau_10, 'alpha_o': g.alpha_o,
           'kappa_d': scenario.kappa_d}
    if scenario.is_si:
        s, sys_ = scenario.scales, scenario.system
        out.update({'t_star_s': s.time_s, 'd_star_m': s.depth_m, 'W_star_N': s.force_N,
                    'torque_scale_C_Nm': s.torque_Nm, 'T_star_zetaC_Nm': s.force_N *
                    sys_.bit_radius_m / 2, 'bha_mass_kg': s.mass_kg,
                    'bha_inertia_kgm2': s.inertia_kgm2,
                    'drive_inertia_kgm2': sys_.drive_inertia_kgm2,
                    'rate_of_penetration_m_s': g.upsilon_o * s.speed_m_s,
                    'rate_of_penetration_m_h': g.upsilon_o * s.speed_m_s * 3600,
                    'G_u': (sys_.pipe_length_m + sys_.bha_length_m) ** 2 / s.time_s ** 2
                    * sys_.density_kg_m3 / sys_.young_modulus_Pa,
                    'G_phi': (sys_.pipe_length_m + sys_.bha_length_m) ** 2 / s.time_s ** 2
                    * sys_.density_kg_m3 / sys_.shear_modulus_Pa})
        # the same operating point in the units a driller reads (API field units)
        rop = g.upsilon_o * s.speed_m_s
        out['field_units'] = {
            'surface_speed_rpm': g.omega_o / s.time_s * 60.0 / (2.0 * math.pi),
            'weight_on_bit_klbf': g.W_o * s.force_N / LBF / 1e3,
            'torque_on_bit_kft_lbf': g.T_o * s.torque_Nm / FT_LBF / 1e3,
            'rate_of_penetration_ft_h': rop * 3600.0 / FT,
            'string_weight_in_mud_klbf': sys_.buoyed_weight_N() / LBF / 1e3,
            'string_length_ft': sys_.total_length_m / FT,
            'mud_density_ppg': sys_.mud_density_kg_m3 / PPG}
    print(json.dumps(out, indent=None if args.json else 2))
    return 0


def cmd_stability(args) -> int:
    from .stability.spectrum import critical_speed, rightmost_roots
    if args.action == 'variable-pitch':
        from .stability.variable_pitch import plot_variable_pitch, variable_pitch_charts
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
        from .stability.gallery import make_gallery
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
        from .stability.linearize import linearize_scenario
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
        _positive(name, v, unit)
    if lo >= hi:
        raise ParameterError(f'--omega-min {lo:g} must be below --omega-max {hi:g} {unit}')
    return lo, hi


def _chart(args, scenario: Scenario) -> int:
    """``stability chart``: a linear sweep (:mod:`drill_twin.sweep`, its results kept in
    ``OUT.sweep/``), drawn and saved as before (PNG, and the chart data as .npz)."""
    from .stability.charts import ChartResult, plot_chart
    from .sweep import SweepSpec, SweepStore, parse_axis, run_sweep
    from .sweep.engine import block_points_for
    if not (args.x and args.y and args.out):
        raise ParameterError('stability chart needs --x, --y and --out')
    x, y = parse_axis(args.x), parse_axis(args.y)
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

    from .sweep.store import holds_other_sweep
    if holds_other_sweep(directory, spec):
        shutil.rmtree(directory)


#: typical cost of one linear chart point [s] (sizes the chart's tasks)
CHART_POINT_S = 1.5e-3


def _discretization(args, scenario: Scenario) -> int:
    from .stability.discretization import chain_sequence, fem_sequence, plot_sequences
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


def cmd_demo(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kernels_ready()       # the speeds below are of the runs, not of a compilation
    results = {}
    for name, overrides in (('benchmark_fem', []),
                            ('benchmark_fem_soft_torque', ['model.top_drive=soft_torque'])):
        scenario = load_scenario('benchmark_fem', overrides)
        series, wall, _ = run_scenario(scenario, progress=Progress(name, sys.stderr.isatty()))
        path = out / f'{name}.npz'
        np.savez_compressed(path, **series)
        summary = stick_slip_summary(series, 0.0)
        summary['wall_s'] = wall
        summary['real_time_factor'] = float(series['time'][-1]) / wall
        results[name] = summary
        print(f'{name}: {summary["samples"]} samples, {_first_stick(summary)}, stick '
              f'fraction {summary["stick_fraction"]:.3f}, '
              f'{summary["real_time_factor"]:.0f}x real time -> {path}')
    # the closed loop the two ROS nodes run: twin (stiff speed drive) + external
    # Soft-Torque controller at 100 Hz, without DDS
    from .physics.closed_loop import run_closed_loop
    from .physics.digital_twin import DigitalTwin
    from .physics.soft_torque import SoftTorqueController, soft_torque_si
    scenario = load_scenario('benchmark_fem')
    tun = soft_torque_si(scenario.system)
    t0 = time.perf_counter()
    loop = run_closed_loop(DigitalTwin(scenario), SoftTorqueController(
        tun['inertia'], tun['stiffness'], tun['damping']), 100.0, scenario.duration *
        scenario.time_unit_s)
    loop_series = {'time': loop['time'], 'bit_angular_speed': loop['bit_angular_speed'],
                   'angular_stick': loop['stuck'], 'command': loop['command'],
                   'bit_axial_speed': loop['bit_axial_speed']}
    np.savez_compressed(out / 'closed_loop_soft_torque.npz', **loop_series)
    stuck = loop['stuck'] > 0.5
    results['closed_loop_soft_torque'] = {
        'first_angular_stick': float(loop['time'][np.argmax(stuck)]) if stuck.any() else None,
        'bit_speed_max': float(loop['bit_angular_speed'].max()),
        'bit_speed_min': float(loop['bit_angular_speed'].min()),
        'wall_s': time.perf_counter() - t0}
    print('closed_loop_soft_torque (twin + external controller at 100 Hz): '
          f"{_first_stick(results['closed_loop_soft_torque'])} "
          f"-> {out / 'closed_loop_soft_torque.npz'}")
    # the benchmark as the twin node publishes it, recorded (replay / resimulate / Foxglove)
    from .io.run_recorder import record_run
    rec = record_run(load_scenario('benchmark_fem'), out / 'benchmark_fem.mcap',
                     scenario.duration * scenario.time_unit_s, config='benchmark_fem')
    results['recording'] = {k: rec[k] for k in ('path', 'messages', 'simulated_s')}
    print(f"recording: {rec['messages']} messages -> {rec['path']} (try: drill-twin mcap plot "
          f"{rec['path']} --out run.png)")
    (out / 'summary.json').write_text(json.dumps(results, indent=2))
    try:
        from .plotting import plot_bit_velocities
        png = out / 'benchmark_fem.png'
        plot_bit_velocities({k: np.load(out / f'{k}.npz') for k in results if k != 'recording'},
                            png)
        print(f'plot -> {png}')
    except ImportError:  # pragma: no cover - matplotlib is a hard dependency
        pass
    print(f'outputs in {out.resolve()}')
    return 0


def _first_stick(summary) -> str:
    t = summary.get('first_angular_stick')
    return 'no angular stick' if t is None else f'first angular stick at {t:.2f} s'


def cmd_reproduce(args) -> int:
    from .reproduce import reproduce
    kernels_ready()
    bar = Progress('figures', sys.stderr.isatty() or args.progress)
    t0 = time.perf_counter()
    summary = reproduce(args.out, args.figure, quick=args.quick, workers=args.workers,
                        progress=lambda fraction, _label: bar(fraction))
    for fig_id, entry in summary.items():
        print(f"Fig. {fig_id:>6}: {Path(args.out) / entry['png']}  ({entry['wall_s']:.1f} s)")
    print(f'{len(summary)} figures in {time.perf_counter() - t0:.0f} s; numbers in '
          f"{Path(args.out) / 'reproduction.json'}")
    return 0


def cmd_compile(args) -> int:
    """``compile``: load the physics kernels, compiling them first on a cold cache (the last
    step of ``make venv``, so that the first run reports its real speed)."""
    wall = kernels_ready()
    from .physics.numba_cache import cache_dir
    print(f'physics kernels ready in {wall:.1f} s (numba cache: {cache_dir()})')
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage block): ``drill-twin simulate: error: ...``"""

    def error(self, message):
        self.exit(2, f'{self.prog}: error: {" ".join(message.split())} (see {self.prog} -h)\n')


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog='drill-twin', description='The offline tool of drill_twin, the digital '
                'twin of a drilling system: simulate, analyse stability, run rig operations, '
                'estimate the bit, record and replay.  `drill-twin COMMAND -h` for each '
                'command.', epilog='README.md and docs/ describe every command.')
    sub = p.add_subparsers(dest='command', required=True, title='commands', metavar='COMMAND')

    def common(sp):
        sp.add_argument('--config', required=True,
                        help='YAML file, or a name in config/ (e.g. benchmark_fem)')
        sp.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='override a configuration value (dotted key), repeatable')

    s = sub.add_parser('simulate', help='run a configuration')
    common(s)
    s.add_argument('--duration', type=float, help='simulated time [s] (SI configs)')
    s.add_argument('--tau', type=float, help='simulated time in units of t*')
    s.add_argument('--out', help='write the time series to this .npz file, or record the '
                   'run as the twin node publishes it to this .mcap file')
    s.add_argument('--rate-hz', type=float, default=100.0,
                   help='.mcap output: measurement rate [Hz] (the node\'s publish rate)')
    s.add_argument('--summary-json', action='store_true', help='print one JSON summary')
    s.add_argument('--stats-from', type=float, default=0.0,
                   help='statistics window start, in the configuration time unit')
    s.set_defaults(func=cmd_simulate)

    s = sub.add_parser('config', help='the configuration schema, or check a configuration')
    s.add_argument('action', choices=['schema', 'check'])
    s.add_argument('--config', help='check: YAML file, or a name in config/')
    s.add_argument('--set', action='append', default=[], metavar='KEY=VALUE')
    s.set_defaults(func=cmd_config)

    s = sub.add_parser('params', help='print derived scales and dimensionless groups')
    common(s)
    s.add_argument('--json', action='store_true')
    s.set_defaults(func=cmd_params)

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

    s = sub.add_parser('demo', help='the make-demo job: benchmark without Soft-Torque, with '
                       'the embedded one, and with the external controller in the loop')
    s.add_argument('--out', default='runs/demo')
    s.set_defaults(func=cmd_demo)
    s = sub.add_parser('reproduce', help="regenerate the thesis's computable figures")
    s.add_argument('--figure', action='append', help='thesis figure id, e.g. 3.3.2 '
                   '(repeatable; default: all)')
    s.add_argument('--out', default='docs/figures', help='output directory')
    s.add_argument('--quick', action='store_true', help='short runs, coarse charts (smoke)')
    s.add_argument('--workers', type=int, default=None, help='chart processes (default: '
                   'all cores)')
    s.add_argument('--progress', action='store_true', help='progress bar even if stderr is '
                   'not a terminal')
    s.set_defaults(func=cmd_reproduce)
    s = sub.add_parser('compile', help="compile the physics kernels into numba's cache (once "
                       'per version and machine; make venv does it)')
    s.set_defaults(func=cmd_compile)
    add_recording_parsers(sub)
    add_operations_parsers(sub)
    add_estimation_parsers(sub)
    add_control_parsers(sub)
    add_sweep_parsers(sub)
    return p


def _terminate(signum, frame):
    raise KeyboardInterrupt  # SIGTERM: unwind like Ctrl-C, so recordings get closed


#: what bad input raises: one line, exit code 2.  Anything else is a bug: its traceback
#: is shown and the exit code is 1.
USER_ERRORS = (ParameterError, SetpointError, SimulationDiverged, RecordingError, OSError)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminate)
    try:
        return args.func(args)
    except BrokenPipeError:  # output piped into e.g. `head`, which closed it: not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except USER_ERRORS as exc:
        print(f'drill-twin: error: {" ".join(str(exc).split())}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print('drill-twin: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
