"""``drill-twin simulate``, ``demo`` and ``compile``: running a configuration offline."""
from __future__ import annotations

import json
import math
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np

from ..analysis.statistics import SERIES_UNITS, stick_slip_summary
from ..config.cli import add_config_arguments
from ..config.scenario import Scenario, load_scenario
from ..console import Progress, kernels_ready, print_summary
from ..errors import ParameterError
from .offline import positive, run_scenario

#: most recorded rows one ``simulate`` keeps in memory (17 channels: 2.3 GB)
MAX_RECORDED_ROWS = 20_000_000


def _duration(args, scenario: Scenario):
    """The run length in t*, from --duration [s] or --tau [t*] (checked in the unit the
    user gave), or the configuration's."""
    if args.duration is not None and args.tau is not None:
        raise ParameterError('give --duration (seconds) or --tau (units of t*), not both')
    if args.duration is not None and not scenario.is_si:
        raise ParameterError('--duration is in seconds, for SI configurations; this one is '
                             'dimensionless: use --tau (units of t*)')
    if args.tau is not None:
        duration = positive('--tau', args.tau, 't*')
    elif args.duration is not None:
        duration = positive('--duration', args.duration, 's') / scenario.time_unit_s
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
    if args.live is not None:
        return _simulate_live(args, scenario, duration, progress)
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


def _simulate_live(args, scenario: Scenario, duration, progress) -> int:
    """The run in real time, served on ws://localhost:PORT (and recorded with --out
    x.mcap)."""
    from ..live.run import PacedFeed, live_topics, run_live
    from ..live.server import LiveView
    if not scenario.is_si:
        raise ParameterError('--live needs an SI configuration (the twin publishes SI)')
    if args.out and not args.out.endswith('.mcap'):
        raise ParameterError('--live records only to .mcap (--out run.mcap)')
    view = LiveView(live_topics(), args.live)
    print(f'drill-twin: live view on {view.url} (Foxglove: Open connection, Foxglove '
          f'WebSocket); {duration * scenario.time_unit_s:g} s in real time, Ctrl-C ends it',
          file=sys.stderr)
    feed = PacedFeed(view)
    try:
        if args.out:
            return _simulate_to_mcap(args, scenario, duration, progress, observe=feed.attach)
        stop = threading.Event()
        previous = {sig: signal.signal(sig, lambda *_: stop.set())
                    for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            out = run_live(scenario, duration * scenario.time_unit_s, feed, args.rate_hz,
                           stop=stop.is_set)
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        out['url'] = view.url
        print_summary(out, args.summary_json)
        return 130 if out['stopped'] else 0
    finally:
        view.close()


def _simulate_to_mcap(args, scenario: Scenario, duration, progress, observe=None) -> int:
    """The run as the twin node would publish it, recorded (simulated log time)."""
    from ..io.run_recorder import record_run
    if not scenario.is_si:
        raise ParameterError('MCAP recording needs an SI configuration (the twin publishes SI)')
    stop = threading.Event()  # SIGINT/SIGTERM end the run between ticks; the file is closed
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    t0 = time.perf_counter()
    try:
        out = record_run(scenario, args.out, duration * scenario.time_unit_s, args.rate_hz,
                         config=args.config, overrides=args.set, progress=progress,
                         stop=stop.is_set, observe=observe)
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
    from ..control.soft_torque import SoftTorqueController
    from ..physics.parameters import soft_torque_si
    from .closed_loop import run_closed_loop
    from .digital_twin import DigitalTwin
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
    from ..io.run_recorder import record_run
    rec = record_run(load_scenario('benchmark_fem'), out / 'benchmark_fem.mcap',
                     scenario.duration * scenario.time_unit_s, config='benchmark_fem')
    results['recording'] = {k: rec[k] for k in ('path', 'messages', 'simulated_s')}
    print(f"recording: {rec['messages']} messages -> {rec['path']} (try: drill-twin mcap plot "
          f"{rec['path']} --out run.png)")
    (out / 'summary.json').write_text(json.dumps(results, indent=2))
    try:
        from ..plotting import plot_bit_velocities
        png = out / 'benchmark_fem.png'
        plot_bit_velocities({k: np.load(out / f'{k}.npz') for k in results if k != 'recording'},
                            png)
        print(f'plot -> {png}')
    except ImportError:  # pragma: no cover - matplotlib is a hard dependency
        pass
    from ..drilling_log import write_log
    from ..io.mcap_reader import open_recording
    log = write_log(open_recording(rec['path']), out / 'benchmark_fem_log',
                    title='benchmark_fem')
    print(f"driller's log -> {log['png']}, {log['html']}")
    print(f'outputs in {out.resolve()}')
    return 0


def _first_stick(summary) -> str:
    t = summary.get('first_angular_stick')
    return 'no angular stick' if t is None else f'first angular stick at {t:.2f} s'


def cmd_compile(args) -> int:
    """``compile``: load the physics kernels, compiling them first on a cold cache (the last
    step of ``make venv``, so that the first run reports its real speed)."""
    wall = kernels_ready()
    from ..physics.numba_cache import cache_dir
    print(f'physics kernels ready in {wall:.1f} s (numba cache: {cache_dir()})')
    return 0


def add_live_argument(parser):
    """``--live [PORT]``: serve the run on ws://localhost:PORT in real time."""
    from ..live.server import DEFAULT_PORT

    def port(text):
        value = int(text)
        if not 0 < value < 65536:
            raise ValueError(text)
        return value
    parser.add_argument('--live', nargs='?', const=DEFAULT_PORT, type=port, metavar='PORT',
                        help='run in real time and serve it to Foxglove on ws://localhost:PORT '
                        f'(localhost only; default port {DEFAULT_PORT})')


def register(sub):
    """Add ``simulate``, ``demo``, ``compile`` to the ``drill-twin`` sub-parsers ``sub``."""
    s = sub.add_parser('simulate', help='run a configuration')
    add_config_arguments(s)
    s.add_argument('--duration', type=float, help='simulated time [s] (SI configs)')
    s.add_argument('--tau', type=float, help='simulated time in units of t*')
    s.add_argument('--out', help='write the time series to this .npz file, or record the '
                   'run as the twin node publishes it to this .mcap file')
    s.add_argument('--rate-hz', type=float, default=100.0,
                   help='.mcap output: measurement rate [Hz] (the node\'s publish rate)')
    s.add_argument('--summary-json', action='store_true', help='print one JSON summary')
    s.add_argument('--stats-from', type=float, default=0.0,
                   help='statistics window start, in the configuration time unit')
    add_live_argument(s)
    s.set_defaults(func=cmd_simulate)
    s = sub.add_parser('demo', help='the make-demo job: benchmark without Soft-Torque, with '
                       'the embedded one, and with the external controller in the loop')
    s.add_argument('--out', default='runs/demo')
    s.set_defaults(func=cmd_demo)
    s = sub.add_parser('compile', help="compile the physics kernels into numba's cache (once "
                       'per version and machine; make venv does it)')
    s.set_defaults(func=cmd_compile)
