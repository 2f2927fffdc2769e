"""Scenario files: a timeline of operations on a configuration (one-line errors).

A scenario is a YAML mapping::

    description: a connection between two stands
    configuration: benchmark_fem          # name in config/ or a path (units: si)
    overrides: [model.axial_top=hoist]    # --set style, optional
    start: rest                           # rest (default) or drilling
    bit_above_bottom_m: 0.5               # at rest: the bit above a flat bottom
    rate_hz: 50                           # control and recording rate
    steps:                                # done one after the other
      - rotate: {rpm: 60, ramp_s: 10}
      - tag_bottom: {speed_m_s: 0.05}
      - slack_off: {wob_N: 60.5e3, ramp_s: 20}
      - wait: {for_s: 60}
      - pick_up: {above_bottom_m: 1.0, speed_m_s: 0.1}
      - stop_rotary: {ramp_s: 5}

Actions (SI; ``rpm`` is accepted beside ``speed_rad_s``, ``wob_kN`` beside ``wob_N``):

``rotate``      ramp the surface speed to ``speed_rad_s``/``rpm`` over ``ramp_s``
``stop_rotary`` ramp the surface speed to 0 over ``ramp_s``
``wait``        hold everything for ``for_s`` (``drill`` is the same word on bottom)
``tag_bottom``  lower the block at ``speed_m_s`` until a blade touches the rock, then
                hold it (``timeout_s``: give up with an error)
``slack_off``   the autodriller takes the weight on bit to ``wob_N`` over ``ramp_s``
                and keeps it there
``pick_up``     autodriller off, raise the block at ``speed_m_s`` until the bit is
                ``above_bottom_m`` above the rock, then hold it
``hold_block``  autodriller off, block stopped
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path

from ..physics.schema import ConfigError

__all__ = ['shipped_scenarios', 'Step', 'Timeline', 'load_timeline', 'ACTIONS', 'RPM']

RPM = 2.0 * math.pi / 60.0

#: action -> {parameter: (unit, low, high, default)}; default None = required
ACTIONS = {
    'rotate': {'speed_rad_s': ('rad/s', 0.0, 100.0, None), 'rpm': ('rpm', 0.0, 1000.0, None),
               'ramp_s': ('s', 0.0, 3600.0, 0.0)},
    'stop_rotary': {'ramp_s': ('s', 0.0, 3600.0, 0.0)},
    'wait': {'for_s': ('s', 0.0, 1e6, None)},
    'drill': {'for_s': ('s', 0.0, 1e6, None)},
    'tag_bottom': {'speed_m_s': ('m/s', 1e-4, 1.0, 0.05), 'timeout_s': ('s', 1.0, 1e5, 300.0)},
    'slack_off': {'wob_N': ('N', 0.0, 1e7, None), 'wob_kN': ('kN', 0.0, 1e4, None),
                  'ramp_s': ('s', 0.0, 3600.0, 0.0)},
    'pick_up': {'above_bottom_m': ('m', 1e-3, 100.0, None),
                'speed_m_s': ('m/s', 1e-4, 1.0, 0.05), 'timeout_s': ('s', 1.0, 1e5, 300.0)},
    'hold_block': {},
}
#: alternatives: (the one kept, the other, factor to the kept unit)
_ALIASES = {'rpm': ('speed_rad_s', RPM), 'wob_kN': ('wob_N', 1e3)}
_TOP_KEYS = ('description', 'configuration', 'overrides', 'start', 'bit_above_bottom_m',
             'rate_hz', 'steps', 'duration_s')


@dataclass(frozen=True)
class Step:
    """One operation of the timeline (parameters in SI)."""

    action: str
    params: dict
    index: int

    @property
    def label(self) -> str:
        shown = ', '.join(f'{k} {v:g}' for k, v in self.params.items()
                          if k not in ('timeout_s',))
        return f'{self.index + 1}. {self.action.replace("_", " ")}' + \
            (f' ({shown})' if shown else '')


@dataclass(frozen=True)
class Timeline:
    """A parsed scenario file."""

    path: Path
    description: str
    configuration: str
    overrides: tuple
    start: str
    bit_above_bottom_m: float
    rate_hz: float
    steps: tuple


def _number(where, key, value, unit, low, high):
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ConfigError(f'{where}: {key} = {value!r}: must be a number in [{low:g}, '
                          f'{high:g}] {unit}')
    try:
        number = float(value)
    except ValueError:
        raise ConfigError(f'{where}: {key} = {value!r}: must be a number in [{low:g}, '
                          f'{high:g}] {unit}') from None
    if not (math.isfinite(number) and low <= number <= high):
        raise ConfigError(f'{where}: {key} = {value!r} {unit}: must be in [{low:g}, '
                          f'{high:g}] {unit}')
    return number


def _step(where, index, item) -> Step:
    if not isinstance(item, dict) or len(item) != 1:
        raise ConfigError(f'{where}: steps[{index}] must be one action mapping, e.g. '
                          "{rotate: {rpm: 120}}")
    action, params = next(iter(item.items()))
    if action not in ACTIONS:
        close = difflib.get_close_matches(str(action), ACTIONS, n=1)
        hint = f' (did you mean {close[0]}?)' if close else ''
        raise ConfigError(f'{where}: steps[{index}]: unknown action {action!r}{hint}; '
                          f'actions: {", ".join(ACTIONS)}')
    params = params or {}
    if not isinstance(params, dict):
        raise ConfigError(f'{where}: steps[{index}].{action} must map parameters, got '
                          f'{params!r}')
    spec = ACTIONS[action]
    out = {}
    for key, value in params.items():
        if key not in spec:
            close = difflib.get_close_matches(str(key), spec, n=1)
            hint = f' (did you mean {close[0]}?)' if close else ''
            raise ConfigError(f'{where}: steps[{index}].{action}: unknown parameter '
                              f'{key!r}{hint}; it takes {", ".join(spec) or "none"}')
        unit, low, high, _ = spec[key]
        number = _number(f'{where}: steps[{index}].{action}', key, value, unit, low, high)
        if key in _ALIASES:
            kept, factor = _ALIASES[key]
            if kept in params:
                raise ConfigError(f'{where}: steps[{index}].{action}: give {kept} or {key}, '
                                  'not both')
            key, number = kept, number * factor
        out[key] = number
    for key, (unit, _, _, default) in spec.items():
        if key in _ALIASES or key in out:
            continue
        if default is None:
            alias = next((a for a, (k, _) in _ALIASES.items() if k == key and a in spec), None)
            also = f' (or {alias})' if alias else ''
            raise ConfigError(f'{where}: steps[{index}].{action} needs {key}{also} [{unit}]')
        out[key] = default
    return Step(action, out, index)


def shipped_scenarios() -> dict:
    """``name: path`` of the scenario files shipped with the package: ``operations/`` of
    every configuration folder (the source tree's ``config/``, or the installed
    ``share/drill_twin/config``), the first folder holding a name winning."""
    from ..physics.scenario import config_dirs
    found = {}
    for folder in config_dirs():
        for path in sorted((folder / 'operations').glob('*.yaml')):
            found.setdefault(path.stem, path)
    return dict(sorted(found.items()))


def load_timeline(path) -> Timeline:
    """Parse and check a scenario file (one-line :class:`ConfigError` on any problem)."""
    path = Path(path)
    if not path.is_file():
        shipped = shipped_scenarios()
        name = path.name[:-5] if path.name.endswith('.yaml') else path.name
        if str(path.parent) != '.' or name not in shipped:
            raise ConfigError(f'{path}: no such scenario file (shipped: '
                              f'{", ".join(shipped) or "none found"})')
        path = shipped[name]
    from ..physics.scenario import read_config
    raw = read_config(path)
    where = str(path)
    if not isinstance(raw, dict):
        raise ConfigError(f'{where}: a scenario must be a mapping')
    for key in raw:
        if key not in _TOP_KEYS:
            close = difflib.get_close_matches(str(key), _TOP_KEYS, n=1)
            hint = f' (did you mean {close[0]}?)' if close else ''
            raise ConfigError(f'{where}: unknown key {key!r}{hint}')
    for key in ('configuration', 'steps'):
        if key not in raw:
            raise ConfigError(f'{where}: missing required key {key}')
    steps = raw['steps']
    if not isinstance(steps, list) or not steps:
        raise ConfigError(f'{where}: steps must be a non-empty list of actions')
    overrides = raw.get('overrides') or []
    if not isinstance(overrides, list) or not all(isinstance(o, str) for o in overrides):
        raise ConfigError(f'{where}: overrides must be a list of KEY=VALUE strings')
    start = raw.get('start', 'rest')
    if start not in ('rest', 'drilling'):
        raise ConfigError(f'{where}: start = {start!r}: must be rest or drilling')
    gap = _number(where, 'bit_above_bottom_m', raw.get('bit_above_bottom_m', 0.5), 'm', 1e-3,
                  100.0)
    rate = _number(where, 'rate_hz', raw.get('rate_hz', 50.0), 'Hz', 1.0, 1000.0)
    return Timeline(path, str(raw.get('description', '')), str(raw['configuration']),
                    tuple(overrides), start, gap, rate,
                    tuple(_step(where, i, item) for i, item in enumerate(steps)))


def timeline_text(timeline: Timeline) -> str:
    """The steps as a person reads them, one per line."""
    return '\n'.join(step.label for step in timeline.steps)
