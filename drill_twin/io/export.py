"""Recordings as tables: CSV per topic (units in the header), a LAS 2.0 drilling log, and
time series for plots.

LAS (Log ASCII Standard 2.0, written with ``lasio``): one time-indexed log of the twin's
scalar channels (:data:`LAS_CURVES`: mnemonic, unit, description, topic, field), one row
per recorded tick (the measurement topics of a tick share its log time; a channel missing
at a tick is the LAS null value).  Units are SI, as on the topics.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from .mcap_reader import Recording

__all__ = ['flatten', 'export_csv', 'export_las', 'topic_series', 'LAS_CURVES', 'field_unit',
           'field_value']

#: LAS curves: mnemonic, unit, description, topic, dotted field
LAS_CURVES = (
    ('TDSPD', 'rad/s', 'top-drive (surface) angular speed', 'surface/top_drive_speed', 'data'),
    ('STOR', 'N.m', 'surface torque (string, first element)', 'surface/torque', 'data'),
    ('HKLD', 'N', 'hook load', 'surface/hook_load', 'data'),
    ('BLKV', 'm/s', 'travelling-block velocity, downward', 'surface/block_velocity', 'data'),
    ('BITRS', 'rad/s', 'bit angular speed', 'bit/velocity', 'twist.angular.x'),
    ('BITVA', 'm/s', 'bit axial speed, downward', 'bit/velocity', 'twist.linear.x'),
    ('WOB', 'N', 'weight on bit', 'bit/wrench', 'wrench.force.x'),
    ('TOB', 'N.m', 'torque on bit', 'bit/wrench', 'wrench.torque.x'),
    ('DOC', 'm', 'depth of cut per revolution', 'bit/depth_of_cut', 'data'),
    ('ROP', 'm/s', 'rate of penetration', 'bit/rate_of_penetration', 'data'),
    ('HAB', 'm', 'bit height above bottom', 'bit/height_above_bottom', 'data'),
    ('STUCK', '', 'bit stuck angularly (1) or turning (0)', 'bit/stuck', 'data'),
    ('SSEV', '', 'stick-slip severity (max-min)/(2 mean)', 'bit/stick_slip_severity', 'data'),
)
_UNITS = {(topic, field): unit for _, unit, _, topic, field in LAS_CURVES}


def field_unit(topic: str, field: str) -> str:
    """SI unit of a recorded field ('' if dimensionless or unknown)."""
    return _UNITS.get((topic.strip('/'), field), '')


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
                writers[topic].writerow(['log_time [s]', *(
                    f'{k} [{field_unit(topic, k)}]' if field_unit(topic, k) else k
                    for k in row)])
                paths[topic] = path
            writers[topic].writerow([f'{t_ns * 1e-9:.9f}', *(
                int(v) if isinstance(v, bool) else v for v in row.values())])
    finally:
        for f in files.values():
            f.close()
    return paths


def field_value(msg, dotted: str):
    """The field ``a.b.c`` of a decoded message."""
    for part in dotted.split('.'):
        msg = getattr(msg, part)
    return msg


def export_las(recording: Recording, path, well: str = 'drill_twin') -> Path:
    """Write the LAS 2.0 log of a recording (module docstring); returns the path."""
    import lasio
    rows: dict[int, dict] = {}
    for topic, t_ns, msg in recording.decoded():
        name = topic.strip('/')
        curves = [c for c in LAS_CURVES if name == c[3] or name.endswith('/' + c[3])]
        if not curves:
            continue
        row = rows.setdefault(t_ns, {})
        for mnem, _, _, _, field in curves:
            row[mnem] = float(field_value(msg, field))
    if not rows:
        raise ValueError("the recording has none of the twin's measurement topics")
    times = np.array(sorted(rows))
    las = lasio.LASFile()
    las.well['WELL'].value = well
    las.well['NULL'].value = -999.25
    las.other = 'Exported by drill_twin from an MCAP recording; TIME = log time.'
    las.append_curve('TIME', times * 1e-9, unit='s', descr='log time')
    for mnem, unit, descr, _, _ in LAS_CURVES:
        col = np.array([rows[t].get(mnem, np.nan) for t in times])
        if not np.all(np.isnan(col)):
            las.append_curve(mnem, col, unit=unit, descr=descr)
    for key, value in (('STRT', times[0]), ('STOP', times[-1])):
        las.well[key].value, las.well[key].unit = value * 1e-9, 's'
    steps = np.diff(times)
    las.well['STEP'].value = float(steps[0]) * 1e-9 if steps.size and not np.ptp(steps) else 0.0
    las.well['STEP'].unit = 's'
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, 'w') as f:
        las.write(f, version=2.0, fmt='%.12g')   # 12 digits: the values read back
    return path


def topic_series(recording: Recording, topic: str, fields) -> dict:
    """Arrays ``{'time_s': ..., field: ...}`` of dotted ``fields`` of one topic."""
    times, cols = [], {f: [] for f in fields}
    for _, t_ns, msg in recording.decoded([topic]):
        times.append(t_ns * 1e-9)
        for f in fields:
            cols[f].append(float(field_value(msg, f)))
    out = {'time_s': np.asarray(times)}
    out.update({f: np.asarray(v) for f, v in cols.items()})
    return out
