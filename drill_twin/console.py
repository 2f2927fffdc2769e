"""Console output shared by the ``drill-twin`` sub-commands."""
from __future__ import annotations

import json
import math
import sys

__all__ = ['print_summary', 'human', 'Progress']


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
        print(json.dumps(out))
        return
    for key, value in out.items():
        if isinstance(value, dict):
            print(f'{key:>{width}}:')
            for sub, item in value.items():
                print(f'{"":>{width}}  {sub}: {human(item)}')
        else:
            print(f'{key:>{width}}: {human(value)}')


class Progress:
    """A minimal progress bar on stderr (only when it is a terminal, or forced)."""

    def __init__(self, label: str, enabled: bool):
        self.label = label
        self.enabled = enabled
        self.last = -1

    def __call__(self, fraction: float):
        if not self.enabled:
            return
        pct = int(100 * fraction)
        if pct != self.last:
            self.last = pct
            bar = '#' * (pct // 4)
            sys.stderr.write(f'\r{self.label} [{bar:<25}] {pct:3d}%')
            if pct >= 100:
                sys.stderr.write('\n')
            sys.stderr.flush()
