"""Console output shared by the ``drill-twin`` sub-commands: summaries, progress, and the
one-time compilation of the physics kernels said out loud."""
from __future__ import annotations

import json
import math
import sys
import time

__all__ = ['print_summary', 'human', 'Progress', 'LogProgress', 'prepare_kernels',
           'kernels_ready', 'COMPILE_NOTICE']


def human(value, digits: int = 6) -> str:
    """A value as a person reads it: floats to ``digits`` significant digits, None as
    'none', lists element by element."""
    if value is None:
        return 'none'
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f'{value:.{digits}g}' if math.isfinite(value) else str(value)
    if isinstance(value, (list, tuple)):
        if value and all(isinstance(v, (list, tuple)) and len(v) == 2 for v in value):
            # (real, imaginary) pairs: complex roots
            return ', '.join(f'{human(re, digits)}{"+" if im >= 0 else "-"}'
                             f'{human(abs(im), digits)}j' for re, im in value)
        return ', '.join(human(v, digits) for v in value)
    return str(value)


def print_summary(out: dict, as_json: bool, width: int = 22):
    """One JSON line (full precision), or one ``key: value`` line per entry with keys
    right-aligned, floats rounded; a nested mapping is printed one entry per line."""
    if as_json:
        print(json.dumps(out, allow_nan=False, default=_json_default))
        return
    for key, value in out.items():
        if isinstance(value, dict):
            print(f'{key:>{width}}:')
            for sub, item in value.items():
                print(f'{"":>{width}}  {sub}: {human(item)}')
        else:
            print(f'{key:>{width}}: {human(value)}')


def _json_default(value):
    raise TypeError(f'{type(value).__name__} is not JSON serialisable')


def _duration(seconds: float) -> str:
    seconds = max(0, int(round(seconds)))
    if seconds < 60:
        return f'{seconds} s'
    minutes, seconds = divmod(seconds, 60)
    if minutes < 60:
        return f'{minutes} min {seconds:02d} s'
    hours, minutes = divmod(minutes, 60)
    return f'{hours} h {minutes:02d} min'


class Progress:
    """A progress bar on stderr, only when it is a terminal (or forced): the fraction done,
    an optional count (``detail``, e.g. '12/40 blocks') and the time left, extrapolated
    from the time so far.  Redrawn at most five times a second; ``--json`` output on
    stdout is never touched."""

    def __init__(self, label: str, enabled: bool, stream=None):
        self.label = label
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.start = time.monotonic()
        self.last_draw = -math.inf
        self.finished = False

    def __call__(self, fraction: float, detail: str = ''):
        if not self.enabled or self.finished:
            return
        now = time.monotonic()
        fraction = min(max(float(fraction), 0.0), 1.0)
        if fraction < 1.0 and now - self.last_draw < 0.2:
            return
        self.last_draw = now
        pct = int(100 * fraction)
        bar = '#' * (pct // 4)
        elapsed = now - self.start
        if fraction >= 1.0:
            when = f'done in {_duration(elapsed)}'
        elif fraction > 0.0 and elapsed > 2.0:
            when = f'{_duration(elapsed * (1.0 - fraction) / fraction)} left'
        else:
            when = ''
        text = ', '.join(t for t in (detail, when) if t)
        self.stream.write(f'\r{self.label} [{bar:<25}] {pct:3d}%  {text}\033[K')
        if fraction >= 1.0:
            self.stream.write('\n')
            self.finished = True
        self.stream.flush()


#: what a cold start says before it compiles (the figure is this machine's kind: 2 cores)
COMPILE_NOTICE = ('compiling the physics kernels into numba\'s cache: once per version of '
                  'the sources and per machine, about a minute on 2 cores ({where})')


def prepare_kernels(say=None, progress=None) -> float:
    """Load the physics kernels from numba's cache, or compile them, saying so first.

    Parameters
    ----------
    say : callable, optional
        ``say(line)`` for the notice before a compilation and the line after it (default:
        print to stderr); nothing is said when the cache is warm.
    progress : callable, optional
        ``progress(fraction, detail)`` while compiling (e.g. a :class:`Progress`).

    Returns
    -------
    float
        Seconds spent [s] (loading a warm cache takes a fraction of a second).
    """
    from .physics import kernel, numba_cache
    from .physics.jit import COMPILED_FUNCTIONS
    from .physics.simulation import compile_kernels
    say = say or (lambda line: print(line, file=sys.stderr, flush=True))
    t0 = time.perf_counter()
    if numba_cache.is_cached(kernel.advance) and numba_cache.is_cached(kernel.snapshot):
        compile_kernels()
        return time.perf_counter() - t0
    say(COMPILE_NOTICE.format(where=numba_cache.cache_dir()))
    with _CompileCounter(len(COMPILED_FUNCTIONS), progress):
        compile_kernels()
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(1.0, f'{len(COMPILED_FUNCTIONS)} functions')
    say(f'kernels compiled in {wall:.0f} s; later runs load them from the cache')
    return wall


def kernels_ready() -> float:
    """:func:`prepare_kernels` for a command line: the notice on stderr and a progress bar
    when stderr is a terminal.  Commands call it before they time a run, so that the speed
    they report never includes the compilation."""
    return prepare_kernels(progress=Progress('compiling', sys.stderr.isatty()))


class LogProgress:
    """A progress report as log lines (a node's logger, which is not a terminal): one line
    at most every ``every_s`` seconds, and the last."""

    def __init__(self, log, label: str, every_s: float = 10.0):
        self.log, self.label, self.every_s = log, label, every_s
        self.last = time.monotonic()

    def __call__(self, fraction: float, detail: str = ''):
        now = time.monotonic()
        if fraction >= 1.0 or now - self.last >= self.every_s:
            self.last = now
            self.log(f'{self.label}: {int(100 * min(fraction, 1.0))} % ({detail})')


class _CompileCounter:
    """Counts numba's finished compilations of drill_twin functions (numba's event API),
    and reports them to ``progress`` as a fraction of ``total``."""

    def __init__(self, total: int, progress):
        self.total = max(1, total)
        self.progress = progress
        self.done = 0
        self.listener = None

    def __enter__(self):
        if self.progress is None:
            return self
        from numba.core import event

        counter = self

        class Listener(event.Listener):
            def on_start(self, ev):
                pass

            def on_end(self, ev):
                dispatcher = (ev.data or {}).get('dispatcher')
                module = getattr(getattr(dispatcher, 'py_func', None), '__module__', '')
                if module.startswith('drill_twin.'):
                    counter.done += 1
                    counter.progress(min(counter.done / counter.total, 0.99),
                                     f'{min(counter.done, counter.total)}/{counter.total} '
                                     'functions')

        self.listener = Listener()
        event.register('numba:compile', self.listener)
        self.progress(0.0, f'0/{self.total} functions')
        return self

    def __exit__(self, *exc):
        if self.listener is not None:
            from numba.core import event
            event.unregister('numba:compile', self.listener)
        return False
