"""The well path of a configuration: ``well.survey`` (a survey file) → a
:class:`~drill_twin.physics.well_path.WellPath`; no survey: the vertical well.

A survey file is CSV text: a header line, then one station per line, ``measured depth
[m], inclination [deg], azimuth [deg]``, the first station at 0 m, depths increasing.
It is looked up as given (absolute, or relative to the working directory), then in
``config/wells/`` of each configuration directory (:func:`~drill_twin.config.lookup.
config_dirs`).  Every problem is one :class:`~drill_twin.errors.ConfigError` line naming
the file and the line.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import ConfigError, ParameterError
from ..physics.well_path import WellPath
from .lookup import config_dirs, is_file
from .yaml_bounds import read_text, shown

__all__ = ['read_survey', 'scenario_well', 'resolve_survey', 'MAX_SURVEY_BYTES',
           'MAX_STATIONS']

#: largest survey file read [bytes] and most stations (a station every 1 m over 20 km is
#: 20,000 lines of ~30 bytes)
MAX_SURVEY_BYTES = 1 << 20
MAX_STATIONS = 100_000


def resolve_survey(name) -> Path:
    """The file a ``well.survey`` value names (see the module docstring)."""
    path = Path(name)
    if is_file(path):
        return path
    for folder in config_dirs():
        for candidate in (folder / 'wells' / path, folder / 'wells' / f'{path}.csv'):
            if is_file(candidate):
                return candidate
    known = sorted({p.name for d in config_dirs() if (d / 'wells').is_dir()
                    for p in (d / 'wells').glob('*.csv')})
    raise ConfigError(f'well.survey = {shown(str(name))!r}: no such survey file (in config/wells/: '
                      f'{", ".join(known) or "none"})')


def read_survey(path) -> WellPath:
    """The well path of a survey file (module docstring)."""
    path = Path(path)
    lines = read_text(path, MAX_SURVEY_BYTES, 'survey file').splitlines()
    content = [(number, line) for number, line in enumerate(lines, start=1)
               if line.strip() and not line.lstrip().startswith('#')]
    rows = [_station(path, number, line) for number, line in content[1:]]   # after the header
    if len(rows) < 2 or len(rows) > MAX_STATIONS:
        raise ConfigError(f'{path}: {len(rows)} stations; a survey needs 2 to {MAX_STATIONS} '
                          '(after a header line: measured_depth_m, inclination_deg, '
                          'azimuth_deg)')
    md, inc, azi = np.array(rows).T
    try:
        return WellPath(md, np.radians(inc), np.radians(azi))
    except ParameterError as exc:
        raise ConfigError(f'{path}: {exc}') from None


def _station(path: Path, number: int, line: str) -> tuple:
    parts = [p.strip() for p in line.split(',')]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ConfigError(f'{path}: line {number}: {line[:60]!r} is not three finite numbers '
                          '(measured depth m, inclination deg, azimuth deg)')
    return values


def scenario_well(scenario) -> WellPath:
    """The well path of an SI scenario: its ``well.survey``, else the vertical well to the
    string's length.  A survey shorter than the string is refused."""
    length = scenario.system.total_length_m
    survey = (scenario.raw.get('well') or {}).get('survey')
    if survey is None:
        return WellPath.vertical(length)
    path = read_survey(resolve_survey(survey))
    if path.total_depth_m < length:
        raise ConfigError(f'well.survey {survey}: ends at {path.total_depth_m:g} m, above the '
                          f'bit of the {length:g} m string')
    return path
