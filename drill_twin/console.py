"""Console output shared by the ``drill-twin`` sub-commands."""
from __future__ import annotations

import json

__all__ = ['print_summary']


def print_summary(out: dict, as_json: bool, width: int = 22):
    """One JSON line, or one ``key: value`` line per entry with keys right-aligned."""
    if as_json:
        print(json.dumps(out))
    else:
        for key, value in out.items():
            print(f'{key:>{width}}: {value}')
