"""``drill-twin mcap ...`` and ``drill-twin replay``: the recording sub-commands."""
from __future__ import annotations

import json
from pathlib import Path

from .console import print_summary
from .errors import ParameterError
from .io.mcap_reader import open_recording, recover

__all__ = ['register']


def cmd_mcap(args) -> int:
    if args.action == 'recover':
        if not args.output:
            raise ParameterError('mcap recover needs BROKEN.mcap FIXED.mcap')
        counts = recover(args.file, args.output)
        counts['output'] = args.output
        print_summary(counts, args.json, width=24)
        return 0
    rec = open_recording(args.file)
    if args.action == 'info':
        run = rec.run
        out = {'library': rec.library, 'messages': sum(rec.message_counts.values()),
               'topics': {t: f'{ty}, {rec.message_counts.get(t, 0)} messages'
                          for t, ty in sorted(rec.topics.items())},
               'time_base': run.get('time_base', 'unknown (not a drill_twin file)'),
               'model': run.get('model'), 'package_version': run.get('package_version'),
               'git_revision': run.get('git_revision')}
        print_summary(out, args.json, width=24)
    elif args.action == 'export':
        if not (args.csv or args.las):
            raise ParameterError('mcap export needs --csv DIR and/or --las FILE.las')
        from .io.export import export_csv, export_las
        out = {}
        if args.csv:
            out.update({t: str(p) for t, p in export_csv(rec, args.csv, args.topics).items()})
        if args.las:
            try:
                out['las'] = str(export_las(rec, args.las))
            except ValueError as exc:
                raise ParameterError(f'{args.file}: {exc}') from None
        print_summary(out, args.json, width=24)
    elif args.action == 'plot' and args.log:
        from .drilling_log import write_log
        out = args.out or str(Path(args.file).with_name(Path(args.file).stem + '_log'))
        try:
            written = write_log(rec, out, title=Path(args.file).name, depth=args.depth)
        except ValueError as exc:
            raise ParameterError(f'{args.file}: {exc}') from None
        print_summary(written, args.json, width=24)
    elif args.action == 'plot':
        if not args.out:
            raise ParameterError('mcap plot needs --out FILE.png')
        from .io.export import topic_series
        from .plotting import plot_recording
        ns = rec.run.get('namespace', '/').rstrip('/')
        sources = {  # series name: (topic, field)
            'bit_angular_speed_rad_s': ('bit/velocity', 'twist.angular.x'),
            'surface_speed_rad_s': ('surface/top_drive_speed', 'data'),
            'weight_on_bit_N': ('bit/wrench', 'wrench.force.x'),
            'torque_on_bit_Nm': ('bit/wrench', 'wrench.torque.x'),
            'rate_of_penetration_m_s': ('bit/rate_of_penetration', 'data'),
            'stuck': ('bit/stuck', 'data')}
        series = {}
        for key, (topic, fld) in sources.items():
            name = f'{ns}/{topic}'
            if name in rec.topics:
                s = topic_series(rec, name, [fld])
                series.setdefault('time_s', s['time_s'])
                if len(s[fld]) == len(series['time_s']):
                    series[key] = s[fld]
        if 'time_s' not in series:
            raise ParameterError(f'{args.file} has none of the twin measurement topics')
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        plot_recording(series, args.out, title=f'{Path(args.file).name}: '
                       f'{rec.run.get("model", "")}')
        print_summary({'png': args.out, 'samples': len(series['time_s'])}, args.json, width=24)
    return 0


def cmd_replay(args) -> int:
    rec = open_recording(args.file)
    if args.resimulate:
        from .io.resimulation import resimulate
        report = resimulate(rec)
        worst = max((v['max_abs_difference'] for v in report['topics'].values()), default=0.0)
        report['max_abs_difference'] = worst
        if args.json:
            print(json.dumps(report))
        else:
            print(f"{report['ticks']} ticks, {report['setpoints_applied']} set-points applied, "
                  f"{report['setpoints_rejected']} rejected")
            for topic, v in report['topics'].items():
                print(f"{topic:>32}: {v['messages']:7d} messages, max |difference| "
                      f"{v['max_abs_difference']:.3g}")
        return 0 if worst <= args.tolerance else 1
    from .io.mcap_reader import check_decodable
    check_decodable(rec, args.topics)  # nothing is published from a file that does not decode
    import rclpy

    from .ros.player import Player
    rclpy.init()
    try:
        player = Player(rec, args.topics, args.rate, args.as_fast_as_possible)
        if args.delay > 0:  # let subscribers discover the new publishers
            import time
            time.sleep(args.delay)
        n = player.play()
        print(f'published {n} messages from {args.file}')
        player.destroy_node()
    except KeyboardInterrupt:
        pass
    finally:
        if rclpy.ok():
            rclpy.shutdown()
    return 0


def register(sub):
    s = sub.add_parser('mcap', help='inspect, recover, export or plot a recording')
    s.add_argument('action', choices=['info', 'recover', 'export', 'plot'])
    s.add_argument('file', help='the .mcap recording')
    s.add_argument('output', nargs='?', help='recover: the repaired file to write')
    s.add_argument('--csv', help='export: directory for one CSV per topic (units in the '
                   'header)')
    s.add_argument('--las', help='export: LAS 2.0 drilling log of the scalar channels')
    s.add_argument('--topics', nargs='+', help='export: only these topics')
    s.add_argument('--out', help='plot: PNG file; with --log: .png, .html, or a stem for both '
                   '(default: RUN_log.png and RUN_log.html beside the recording)')
    s.add_argument('--log', action='store_true', help="plot: the driller's log (hook load & "
                   'WOB, RPM, torque, ROP, stick-slip severity tracks) to PNG and HTML')
    s.add_argument('--depth', action='store_true', help='plot --log: drilled depth as the '
                   'index axis instead of time')
    s.add_argument('--json', action='store_true')
    s.set_defaults(func=cmd_mcap)

    s = sub.add_parser('replay', help='republish a recording, or resimulate it')
    s.add_argument('file', help='the .mcap recording')
    s.add_argument('--rate', type=float, default=1.0, help='playback speed factor')
    s.add_argument('--topics', nargs='+', help='only these (recorded) topic names')
    s.add_argument('--as-fast-as-possible', action='store_true',
                   help='no pacing; publish /clock with the recorded log time')
    s.add_argument('--delay', type=float, default=0.5,
                   help='seconds to wait for subscribers before the first message')
    s.add_argument('--resimulate', action='store_true', help='feed the recorded set-points '
                   'into a fresh twin and compare its outputs with the recording')
    s.add_argument('--tolerance', type=float, default=0.0,
                   help='resimulate: exit 1 when a difference exceeds this')
    s.add_argument('--json', action='store_true')
    s.set_defaults(func=cmd_replay)
