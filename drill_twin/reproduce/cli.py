"""``drill-twin reproduce``: the thesis's computable figures."""
from __future__ import annotations

import sys
import time
from pathlib import Path

from ..console import Progress, kernels_ready


def cmd_reproduce(args) -> int:
    from . import reproduce
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


def register(sub):
    """Add ``reproduce`` to the ``drill-twin`` sub-parsers ``sub``."""
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
