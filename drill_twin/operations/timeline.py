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
                (linear), or with ``time_constant_s`` (first order: the step lasts five
                time constants, the set-point then within 0.7 % of its target)
``stop_rotary`` ramp the surface speed to 0 over ``ramp_s``
``wait``        hold everything for ``for_s`` (``drill`` is the same word on bottom)
``tag_bottom``  lower the block at ``speed_m_s`` until a blade touches the rock, then
                hold it (``timeout_s``: give up with an error)
``slack_off``   the autodriller takes the weight on bit to ``wob_N`` over ``ramp_s``
                and keeps it there
``pick_up``     autodriller off, raise the block at ``speed_m_s`` until the bit is
                ``above_bottom_m`` above the rock, then hold it
``hold_block``  autodriller off, block stopped

Checks (each a one-line error naming the file): every key is known (``duration_s`` is
not one: a scenario lasts as long as its steps) and applies (``bit_above_bottom_m`` only
to ``start: rest``); every number is finite and inside its range; the configuration is
loaded with the overrides and must be SI, have a block (``model.axial_top: hoist`` or
``velocity``) if a step moves one, and weigh more than any ``slack_off`` target; the
longest the steps can take (ramps, waits, timeouts) is at most :data:`MAX_RUN_TICKS`
ticks at ``rate_hz``, which bounds what a run keeps in memory.  The file itself is read
with the bounds of :func:`drill_twin.config.yaml_bounds.parse_yaml` (size, nesting,
aliases, integer digits).
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from .driller import FIRST_ORDER_SPAN, ScenarioError

__all__ = ['shipped_scenarios', 'Step', 'Timeline', 'load_timeline', 'parse_timeline',
           'check_configuration', 'ACTIONS', 'RPM',
           'MAX_RUN_TICKS', 'MAX_STEP_S']

RPM = 2.0 * math.pi / 60.0
#: longest wait, drill or timeout of one step [s]: a day (a connection takes minutes, a
#: drilling run between connections under an hour)
MAX_STEP_S = 86_400.0
#: most control ticks a scenario may take, its steps at their longest (waits, ramps,
#: timeouts; at least one tick each).  An offline run keeps 11 series of a float per
#: tick: 0.44 kB a tick at its peak (measured: the lists, then their arrays), so 10^6
#: ticks bound it near 0.45 GB; that is 5.5 h at 50 Hz or 17 min at 1000 Hz.  The
#: shipped scenarios take at most 4·10^4.
MAX_RUN_TICKS = 1_000_000

#: action -> {parameter: (unit, low, high, default)}; default None = required
ACTIONS = {
    'rotate': {'speed_rad_s': ('rad/s', 0.0, 100.0, None), 'rpm': ('rpm', 0.0, 1000.0, None),
               'ramp_s': ('s', 0.0, 3600.0, 0.0), 'time_constant_s': ('s', 0.0, 600.0, 0.0)},
    'stop_rotary': {'ramp_s': ('s', 0.0, 3600.0, 0.0)},
    'wait': {'for_s': ('s', 0.0, MAX_STEP_S, None)},
    'drill': {'for_s': ('s', 0.0, MAX_STEP_S, None)},
    'tag_bottom': {'speed_m_s': ('m/s', 1e-4, 1.0, 0.05),
                   'timeout_s': ('s', 1.0, MAX_STEP_S, 300.0)},
    'slack_off': {'wob_N': ('N', 0.0, 1e7, None), 'wob_kN': ('kN', 0.0, 1e4, None),
                  'ramp_s': ('s', 0.0, 3600.0, 0.0)},
    'pick_up': {'above_bottom_m': ('m', 1e-3, 100.0, None),
                'speed_m_s': ('m/s', 1e-4, 1.0, 0.05),
                'timeout_s': ('s', 1.0, MAX_STEP_S, 300.0)},
    'hold_block': {},
}
#: the parameter that bounds how long each action can take [s] (None: one tick)
_LONGEST = {'rotate': 'ramp_s', 'stop_rotary': 'ramp_s', 'wait': 'for_s', 'drill': 'for_s',
            'tag_bottom': 'timeout_s', 'slack_off': 'ramp_s', 'pick_up': 'timeout_s',
            'hold_block': None}
#: actions that move the block
_BLOCK_ACTIONS = ('tag_bottom', 'pick_up')
#: alternatives: (the one kept, the other, factor to the kept unit)
_ALIASES = {'rpm': ('speed_rad_s', RPM), 'wob_kN': ('wob_N', 1e3)}
_TOP_KEYS = ('description', 'configuration', 'overrides', 'start', 'bit_above_bottom_m',
             'rate_hz', 'steps')


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
    """A finite number in [low, high] from a YAML number or numeric string."""
    rule = f'must be a number in [{low:g}, {high:g}] {unit}'
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ConfigError(f'{where}: {key} = {_shown(value)}: {rule}')
    try:
        number = float(value)
    except (ValueError, OverflowError):
        raise ConfigError(f'{where}: {key} = {_shown(value)}: {rule}') from None
    if not (math.isfinite(number) and low <= number <= high):
        raise ConfigError(f'{where}: {key} = {_shown(value)} {unit}: must be in [{low:g}, '
                          f'{high:g}] {unit}')
    return number


def _shown(value, limit: int = 60) -> str:
    """``repr`` of a value for an error line, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else f'{text[:limit]}...({len(text)} characters)'


def _unknown(where, what, key, known, extra: str = '') -> ConfigError:
    """The error for an unknown key, with the nearest known one."""
    close = difflib.get_close_matches(str(key), known, n=1)
    hint = f' (did you mean {close[0]}?)' if close else ''
    return ConfigError(f'{where}: unknown {what} {_shown(key)}{hint}{extra}')


def _step(where, index, item) -> Step:
    if not isinstance(item, dict) or len(item) != 1:
        raise ConfigError(f'{where}: steps[{index}] must be one action mapping, e.g. '
                          "{rotate: {rpm: 120}}")
    action, params = next(iter(item.items()))
    if action not in ACTIONS:
        raise _unknown(f'{where}: steps[{index}]', 'action', action, ACTIONS,
                       f'; actions: {", ".join(ACTIONS)}')
    params = {} if params is None else params
    if not isinstance(params, dict):
        raise ConfigError(f'{where}: steps[{index}].{action} must map parameters, got '
                          f'{_shown(params)}')
    spec = ACTIONS[action]
    out = {}
    for key, value in params.items():
        if key not in spec:
            raise _unknown(f'{where}: steps[{index}].{action}', 'parameter', key, spec,
                           f'; it takes {", ".join(spec) or "none"}')
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
    if out.get('ramp_s', 0.0) > 0.0 and out.get('time_constant_s', 0.0) > 0.0:
        raise ConfigError(f'{where}: steps[{index}].{action}: give ramp_s (linear) or '
                          'time_constant_s (first order), not both')
    return Step(action, out, index)


def _ticks(step: Step, rate_hz: float) -> int:
    """Most control ticks ``step`` can take at ``rate_hz`` (at least one)."""
    longest = _LONGEST[step.action]
    seconds = step.params[longest] if longest else 0.0
    if step.action == 'rotate':
        seconds = max(seconds, FIRST_ORDER_SPAN * step.params['time_constant_s'])
    return max(1, math.ceil(seconds * rate_hz))


def _check_length(where, steps, rate_hz):
    """The steps at their longest fit in :data:`MAX_RUN_TICKS` ticks."""
    ticks = sum(_ticks(step, rate_hz) for step in steps)
    if ticks > MAX_RUN_TICKS:
        raise ConfigError(f'{where}: the steps can take {ticks / rate_hz:.6g} s (waits, '
                          f'ramps and timeouts), {ticks} ticks at {rate_hz:g} Hz: at most '
                          f'{MAX_RUN_TICKS} ticks ({MAX_RUN_TICKS / rate_hz:.6g} s at this '
                          'rate)')


def shipped_scenarios() -> dict:
    """``name: path`` of the scenario files shipped with the package: ``operations/`` of
    every configuration folder (the source tree's ``config/``, or the installed
    ``share/drill_twin/config``), the first folder holding a name winning."""
    from ..config.lookup import config_dirs
    found = {}
    for folder in config_dirs():
        for path in sorted((folder / 'operations').glob('*.yaml')):
            found.setdefault(path.stem, path)
    return dict(sorted(found.items()))


def _scenario_path(path) -> Path:
    """The file a scenario argument names: a path, or a shipped name."""
    from ..config.lookup import is_file
    path = Path(path)
    if is_file(path):
        return path
    shipped = shipped_scenarios()
    name = path.name[:-5] if path.name.endswith('.yaml') else path.name
    if str(path.parent) != '.' or name not in shipped:
        raise ConfigError(f'{_shown(str(path), 200)}: no such scenario file (shipped: '
                          f'{", ".join(shipped) or "none found"})')
    return shipped[name]


def _top_level(where, raw: dict):
    """Check the keys of a scenario mapping and the types of its texts."""
    for key in raw:
        if str(key).startswith('duration'):
            raise ConfigError(f'{where}: unknown key {_shown(key)}: a scenario lasts as long '
                              'as its steps (end it with a wait or drill step)')
        if key not in _TOP_KEYS:
            raise _unknown(where, 'key', key, _TOP_KEYS)
    for key in ('configuration', 'steps'):
        if key not in raw:
            raise ConfigError(f'{where}: missing required key {key}')
    if not isinstance(raw['configuration'], str) or not raw['configuration'].strip():
        raise ConfigError(f'{where}: configuration = {_shown(raw["configuration"])}: must be '
                          'the name of a file in config/ or a path')
    description = raw.get('description', '')
    if not isinstance(description, (str, int, float)) or isinstance(description, bool):
        raise ConfigError(f'{where}: description = {_shown(description)}: must be text')


def parse_timeline(path) -> Timeline:
    """Parse and check a scenario file on its own (no configuration loaded): one-line
    :class:`ConfigError` on any problem."""
    from ..config.yaml_bounds import read_yaml
    path = _scenario_path(path)
    where = str(path)
    raw = read_yaml(path)
    if raw is None:
        raise ConfigError(f'{where}: empty scenario (needs configuration and steps)')
    if not isinstance(raw, dict):
        raise ConfigError(f'{where}: a scenario must be a mapping of keys, got '
                          f'{type(raw).__name__}')
    _top_level(where, raw)
    steps = raw['steps']
    if not isinstance(steps, list) or not steps:
        raise ConfigError(f'{where}: steps must be a non-empty list of actions')
    overrides = raw.get('overrides') or []
    if not isinstance(overrides, list) or not all(isinstance(o, str) for o in overrides):
        raise ConfigError(f'{where}: overrides must be a list of KEY=VALUE strings')
    start = raw.get('start', 'rest')
    if start not in ('rest', 'drilling'):
        raise ConfigError(f'{where}: start = {_shown(start)}: must be rest or drilling')
    if start == 'drilling' and 'bit_above_bottom_m' in raw:
        raise ConfigError(f'{where}: bit_above_bottom_m applies to start: rest only (this '
                          'scenario starts drilling, the bit on bottom)')
    gap = _number(where, 'bit_above_bottom_m', raw.get('bit_above_bottom_m', 0.5), 'm', 1e-3,
                  100.0)
    rate = _number(where, 'rate_hz', raw.get('rate_hz', 50.0), 'Hz', 1.0, 1000.0)
    parsed = tuple(_step(where, i, item) for i, item in enumerate(steps))
    _check_length(where, parsed, rate)
    return Timeline(path, str(raw.get('description', '')), raw['configuration'].strip(),
                    tuple(overrides), start, gap, rate, parsed)


def check_configuration(timeline: Timeline):
    """Load the timeline's configuration with its overrides and check that the steps can
    be done on it (:class:`ScenarioError` naming the file and the step): SI, a block for
    the steps that move one, a string that weighs more than every slack-off target."""
    from ..config.scenario import load_scenario
    scenario = load_scenario(timeline.configuration, list(timeline.overrides),
                             label=f'{timeline.path} overrides:', check_step=False)
    where = f'{timeline.path}: configuration {timeline.configuration}'
    if not scenario.is_si:
        raise ScenarioError(f'{where} is units: dimensionless; the twin runs SI '
                            'configurations (units: si)')
    top = scenario.raw['model'].get('axial_top') or 'hook_load'
    weight = scenario.system.buoyed_weight_N()
    for step in timeline.steps:
        if step.action in _BLOCK_ACTIONS and top not in ('hoist', 'velocity'):
            raise ScenarioError(f'{timeline.path}: {step.label}: needs a block '
                                '(model.axial_top: hoist or velocity; e.g. overrides: '
                                f'[model.axial_top=hoist]); {timeline.configuration} hangs '
                                'on a constant hook load')
        if step.action == 'slack_off' and step.params['wob_N'] > weight:
            raise ScenarioError(f'{timeline.path}: {step.label}: the weight on bit '
                                f"{step.params['wob_N'] / 1e3:g} kN is more than the string "
                                f'weighs in mud ({weight / 1e3:.4g} kN)')


def load_timeline(path) -> Timeline:
    """Parse and check a scenario file (:func:`parse_timeline`) and check it against its
    configuration (:func:`check_configuration`); one-line errors naming the file."""
    timeline = parse_timeline(path)
    check_configuration(timeline)
    return timeline


def timeline_text(timeline: Timeline) -> str:
    """The steps as a person reads them, one per line."""
    return '\n'.join(step.label for step in timeline.steps)
