"""Flatten recorded messages into columns: CSV export and time series for plots."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from .mcap_reader import Recording

__all__ = ['flatten', 'export_csv', 'topic_series']


def flatten(msg, prefix: str = '') -> dict:
    """Leaf fields of a decoded message as ``{'twist.angular.x': value}`` (arrays of
    messages become JSON text; arrays of numbers stay lists)."""
    out = {}
    slots = getattr(msg, '__slots__', None)
    if slots is None:
        return {prefix.rstrip('.'): msg}
    for name in slots:
        value = getattr(msg, name)
        key = f'{prefix}{name}'
        if hasattr(value, '__slots__'):
            out.update(flatten(value, key + '.'))
        elif isinstance(value, (list, tuple)) and value and hasattr(value[0], '__slots__'):
            out[key] = json.dumps([flatten(v) for v in value], default=str)
        else:
            out[key] = value
    return out


def export_csv(recording: Recording, out_dir, topics=None) -> dict:
    """One CSV per topic (``log_time_s`` then every leaf field); returns ``{topic: path}``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files, writers, paths = {}, {}, {}
    try:
        for topic, t_ns, msg in recording.decoded(topics):
            row = flatten(msg)
            if topic not in writers:
                path = out_dir / (topic.strip('/').replace('/', '__') + '.csv')
                files[topic] = open(path, 'w', newline='')  # noqa: SIM115 - closed below
                writers[topic] = csv.writer(files[topic])
                writers[topic].writerow(['log_time_s', *row])
                paths[topic] = path
            writers[topic].writerow([f'{t_ns * 1e-9:.9f}', *(
                int(v) if isinstance(v, bool) else v for v in row.values())])
    finally:
        for f in files.values():
            f.close()
    return paths


def topic_series(recording: Recording, topic: str, fields) -> dict:
    """Arrays ``{'time_s': ..., field: ...}`` of dotted ``fields`` of one topic."""
    times, cols = [], {f: [] for f in fields}
    for _, t_ns, msg in recording.decoded([topic]):
        times.append(t_ns * 1e-9)
        for f in fields:
            value = msg
            for part in f.split('.'):
                value = getattr(value, part)
            cols[f].append(float(value))
    out = {'time_s': np.asarray(times)}
    out.update({f: np.asarray(v) for f, v in cols.items()})
    return out
