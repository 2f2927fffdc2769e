"""What a sweep computes, as plain data: the configuration, the grid axes, the kind, the
statistics, the Monte Carlo distributions and the blocks the grid is cut into.

A :class:`SweepSpec` is JSON-serialisable (``to_json`` / ``from_json``): it is stored
beside the results so that an interrupted sweep resumes on exactly the same points and
blocks, and it is what every Dask task receives.  Monte Carlo samples are drawn once,
here, from a seeded generator: every worker and every resumption sees the same numbers.

A spec is checked when it is made (from the command line or from a stored ``spec.json``),
before any work: every value the sweep assigns to a configuration key — each axis's
values, each distribution's draws — passes the configuration schema
(:func:`drill_twin.config.schema.validate`, with its did-you-mean for unknown keys), a
key the configuration would ignore is refused, and the grid, the samples and the blocks
are bounded before anything is allocated.  Every refusal is a
:class:`~drill_twin.errors.ParameterError` (one line).
"""
from __future__ import annotations

import difflib
import json
import math
import re
from dataclasses import asdict, dataclass, fields

import numpy as np

from ..config.scenario import with_values
from ..config.schema import validate
from ..errors import ConfigError, ParameterError

__all__ = ['Axis', 'Distribution', 'SweepSpec', 'parse_axis', 'parse_distribution',
           'parse_stats', 'KINDS', 'LINEAR_OUTPUTS', 'NONLINEAR_STATS', 'DEFAULT_STATS',
           'UPSILON_O', 'MAX_POINTS', 'MAX_AXIS_VALUES', 'MAX_SAMPLES', 'MAX_BLOCKS']

KINDS = ('linear', 'nonlinear')
#: what a linear sweep stores per point
LINEAR_OUTPUTS = ('abscissa', 'unstable')
#: statistics of ``drill-twin simulate --summary-json`` a nonlinear sweep can store
NONLINEAR_STATS = ('severity', 'stick_fraction', 'bit_speed_max', 'bit_speed_min',
                   'bit_speed_mean', 'rop_mean', 'first_angular_stick', 'delay_residual_max')
DEFAULT_STATS = ('severity', 'stick_fraction', 'rop_mean')
DISTRIBUTIONS = ('uniform', 'normal', 'lognormal')
#: virtual key of linear sweeps: the dimensionless penetration rate υ_o, realised by
#: W_o = n_b λ + 2π υ_o / ω_o (eq. 2.4.5) at each point
UPSILON_O = 'upsilon_o'
#: configuration keys whose value υ_o replaces (an axis over them would not vary)
WOB_KEYS = ('groups.W_o', 'operating_point.weight_on_bit_N')
#: the simulated time of a nonlinear sweep is its ``duration``, not these keys
DURATION_KEYS = ('simulation.duration', 'simulation.duration_s')

#: most points one sweep holds (its result arrays live in memory when assembled)
MAX_POINTS = 10_000_000
#: most values on one axis (checked before the axis is made)
MAX_AXIS_VALUES = 100_000
#: most Monte Carlo samples per grid point (drawn when the spec is made)
MAX_SAMPLES = 100_000
#: most ``--vary`` distributions (each stores ``samples`` draws in the spec)
MAX_VARY = 16
#: most blocks (one file and one Dask task each)
MAX_BLOCKS = 100_000
#: seeds are integers in [0, MAX_SEED]
MAX_SEED = 2 ** 64 - 1
#: most recorded rows of one nonlinear point (17 channels of 8 bytes: 272 MB a worker)
MAX_ROWS_PER_POINT = 2_000_000
#: recording interval a configuration without one gets [configuration time unit]
DEFAULT_RECORD_INTERVAL = 0.01
#: most digits of an integer in a stored spec (a seed below 2**64 has 20)
MAX_JSON_INT_DIGITS = 20
#: longest key a sweep assigns [characters] (the schema's longest is ~45)
MAX_KEY_CHARS = 200
#: longest piece of a command line quoted in an error [characters]
SHOWN_CHARS = 80


def _shown(text) -> str:
    """``text`` for an error line: cut to :data:`SHOWN_CHARS` characters."""
    text = str(text)
    return text if len(text) <= SHOWN_CHARS else f'{text[:SHOWN_CHARS]}...({len(text)} characters)'


def _check_key(key, what: str) -> None:
    if not isinstance(key, str) or not key.strip() or len(key) > MAX_KEY_CHARS:
        raise ParameterError(f'{what} key {_shown(key)!r}: must be a dotted configuration key '
                             f'(at most {MAX_KEY_CHARS} characters)')


# --- axes -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Axis:
    """A grid axis: a dotted configuration key (or ``upsilon_o``) and its values (finite,
    distinct, at most :data:`MAX_AXIS_VALUES`)."""

    key: str
    values: tuple

    def __post_init__(self):
        _check_key(self.key, 'axis')
        if not 1 <= len(self.values) <= MAX_AXIS_VALUES:
            raise ParameterError(f'axis {self.key}: {len(self.values)} values (allowed: 1 to '
                                 f'{MAX_AXIS_VALUES})')
        try:
            finite = np.isfinite(np.asarray(self.values, dtype=float)).all()
        except (TypeError, ValueError):
            finite = False
        if not finite or len(set(self.values)) < len(self.values):
            raise ParameterError(f'axis {self.key}: the values must be finite and distinct')

    @property
    def size(self) -> int:
        return len(self.values)


def parse_axis(text: str, flag: str = 'axis') -> Axis:
    """``KEY:MIN:MAX:N`` → :class:`Axis`: N ≥ 2 evenly spaced values from MIN to MAX
    (MIN < MAX), or N = 1: the single value MIN (= MAX).  ``flag`` names the option in
    errors.  N is bounded (:data:`MAX_AXIS_VALUES`) before the values are made."""
    where = f'{flag} {_shown(text)}'
    try:
        key, lo, hi, n = str(text).rsplit(':', 3)
        lo, hi, n = float(lo), float(hi), int(n)
    except ValueError:
        raise ParameterError(f'{where}: not KEY:MIN:MAX:N (e.g. groups.omega_o:1:40:25)') \
            from None
    key = key.strip()
    if not key:
        raise ParameterError(f'{where}: no KEY (a dotted configuration key)')
    if not 1 <= n <= MAX_AXIS_VALUES:
        raise ParameterError(f'{where}: N = {_shown(n)}: must be in [1, {MAX_AXIS_VALUES}]')
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f'{where}: MIN and MAX must be finite numbers')
    if (n == 1 and lo != hi) or (n > 1 and not lo < hi):
        raise ParameterError(f'{where}: needs MIN < MAX (N >= 2), or MIN = MAX (N = 1), '
                             f'got MIN {lo:g}, MAX {hi:g}')
    with np.errstate(over='ignore', invalid='ignore'):     # (refused below)
        values = np.linspace(lo, hi, n)
    if not (np.isfinite(values).all() and (np.diff(values) > 0).all()):
        raise ParameterError(f'{where}: {n} values from {lo:g} to {hi:g} are not distinct '
                             'finite numbers')
    return Axis(key, tuple(float(v) for v in values))


# --- Monte Carlo ------------------------------------------------------------------------
@dataclass(frozen=True)
class Distribution:
    """A Monte Carlo distribution of one configuration key.

    ``uniform(low, high)``; ``normal(mean, std)``; ``lognormal(median, sigma)`` (the
    logarithm is normal with mean ln(median) and standard deviation sigma).  The
    parameters are checked when it is made (finite; low < high, std > 0, median > 0 and
    sigma > 0).
    """

    key: str
    kind: str
    a: float
    b: float

    def __post_init__(self):
        _check_key(self.key, '--vary')
        if self.kind not in DISTRIBUTIONS:
            raise ParameterError(f'--vary {self.key}: distribution {_shown(self.kind)!r}: one of '
                                 f'{", ".join(DISTRIBUTIONS)}')
        a, b = self.a, self.b
        numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool)
                      and math.isfinite(v) for v in (a, b))
        if not (numbers and _PARAMETERS_OK[self.kind](a, b)):
            raise ParameterError(f'--vary {self.text}: {self.kind} needs '
                                 f'{_PARAMETERS_RULE[self.kind]}')

    @property
    def text(self) -> str:
        """As written on the command line (``KEY=kind(a,b)``)."""
        return f'{self.key}={self.kind}({self.a!r},{self.b!r})'

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` draws (an overflow gives non-finite draws, refused by the spec)."""
        try:
            with np.errstate(over='ignore', invalid='ignore'):
                if self.kind == 'uniform':
                    return rng.uniform(self.a, self.b, n)
                if self.kind == 'normal':
                    return rng.normal(self.a, self.b, n)
                return rng.lognormal(math.log(self.a), self.b, n)
        except (OverflowError, ValueError):    # numpy refuses the parameters
            return np.full(n, np.inf)


#: what the parameters (a, b) of each distribution must satisfy (finite numbers besides)
_PARAMETERS_OK = {'uniform': lambda a, b: a < b and math.isfinite(b - a),
                  'normal': lambda a, b: b > 0, 'lognormal': lambda a, b: a > 0 and b > 0}
_PARAMETERS_RULE = {'uniform': 'finite LOW < HIGH (and HIGH - LOW finite)',
                    'normal': 'a finite MEAN and a finite STD > 0',
                    'lognormal': 'finite MEDIAN > 0 and SIGMA > 0'}

_DIST = re.compile(r'^\s*([\w.]+)\s*=\s*(\w+)\s*\(\s*([^,()]+?)\s*,\s*([^,()]+?)\s*\)\s*$')


def parse_distribution(text: str) -> Distribution:
    """``KEY=uniform(LOW,HIGH)`` | ``KEY=normal(MEAN,STD)`` | ``KEY=lognormal(MEDIAN,SIGMA)``."""
    m = _DIST.match(str(text))
    if not m or m.group(2) not in DISTRIBUTIONS:
        raise ParameterError(f'--vary {_shown(text)}: not KEY=uniform(LOW,HIGH), '
                             'KEY=normal(MEAN,STD) or KEY=lognormal(MEDIAN,SIGMA)')
    try:
        a, b = float(m.group(3)), float(m.group(4))
    except ValueError:
        raise ParameterError(f'--vary {_shown(text)}: the parameters are not numbers') from None
    return Distribution(m.group(1), m.group(2), a, b)


def parse_stats(names, kind: str) -> tuple:
    """The ``--stat`` names of a sweep of ``kind``: None → :data:`DEFAULT_STATS`; each a
    statistic of :data:`NONLINEAR_STATS`, given once; none for a linear sweep (it stores
    :data:`LINEAR_OUTPUTS`)."""
    if names is None:
        return DEFAULT_STATS
    names = tuple(names)
    if kind != 'nonlinear':
        raise ParameterError(f'--stat {_shown(",".join(map(str, names)))}: statistics are of '
                             f'nonlinear sweeps (--kind nonlinear); a linear one stores '
                             f'{", ".join(LINEAR_OUTPUTS)}')
    _check_stats(names)
    return names


def _check_stats(stats) -> None:
    if not stats:
        raise ParameterError(f'--stat: no statistic (any of {", ".join(NONLINEAR_STATS)})')
    for name in stats:
        if name not in NONLINEAR_STATS:
            close = difflib.get_close_matches(str(name), NONLINEAR_STATS, n=1)
            hint = f' (did you mean {close[0]}?)' if close else ''
            raise ParameterError(f'--stat {_shown(name)!r}: not a statistic of simulate '
                                 f'--summary-json{hint}; one of {", ".join(NONLINEAR_STATS)}')
    repeated = sorted({s for s in stats if stats.count(s) > 1})
    if repeated:
        raise ParameterError(f'--stat {_shown(", ".join(repeated))}: given more than once')


# --- the spec ---------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepSpec:
    """One sweep (see module docstring).

    Parameters
    ----------
    raw : dict
        The configuration mapping (after ``--set`` overrides).
    kind : {'linear', 'nonlinear'}
        ``linear``: rightmost root (``abscissa`` [1/t*, or 1/s for SI configurations]) and
        the number of unstable roots (``unstable``); ``nonlinear``: ``stats`` of a
        simulation of ``duration`` after ``settle`` (the configuration's time unit: s for
        SI configurations, t* otherwise).
    x, y : Axis
        Grid axes (``y`` may be None: a one-dimensional sweep).
    samples : int
        Monte Carlo samples per grid point (0: none); each sample draws every
        distribution of ``vary``.
    seed : int
        Seed of the Monte Carlo draws, in [0, :data:`MAX_SEED`].
    threshold : float
        Linear: real part above which a root counts as unstable [1/t*].
    block_points : int or None
        Points per Dask task (consecutive along ``x``, then ``y``, then the sample); None:
        the fewest that keep the blocks within :data:`MAX_BLOCKS`; more than the grid's
        points: the grid's points (one block).
    """

    raw: dict
    kind: str
    x: Axis
    y: Axis | None = None
    stats: tuple = DEFAULT_STATS
    duration: float = 0.0
    settle: float = 0.0
    samples: int = 0
    vary: tuple = ()
    seed: int = 0
    threshold: float = 1e-9
    block_points: int | None = None
    label: str = ''
    draws: tuple = ()

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ParameterError(f'--kind {self.kind!r}: one of {", ".join(KINDS)}')
        if self.kind == 'nonlinear':
            _check_stats(tuple(self.stats))
            self._check_time()
        if not math.isfinite(self.threshold):
            raise ParameterError(f'--threshold {self.threshold:g}: must be a finite number')
        self._check_monte_carlo()
        self._check_size()
        if self.vary and not self.draws:
            rng = np.random.default_rng(self.seed)
            draws = tuple(tuple(float(v) for v in d.draw(rng, self.samples)) for d in self.vary)
            object.__setattr__(self, 'draws', draws)
        self._check_draws()
        _check_assignments(self)

    def _check_time(self):
        if not (math.isfinite(self.duration) and self.duration > 0
                and math.isfinite(self.settle) and 0 <= self.settle < self.duration):
            raise ParameterError(f'a nonlinear sweep needs --duration > 0 and 0 <= --settle < '
                                 f'--duration, got {self.duration:g}, {self.settle:g}')

    def _check_monte_carlo(self):
        if not 0 <= self.samples <= MAX_SAMPLES:
            raise ParameterError(f'--samples {self.samples}: must be in [0, {MAX_SAMPLES}]')
        if (self.samples > 0) != bool(self.vary):
            raise ParameterError('Monte Carlo needs both --samples N (N >= 1) and at least one '
                                 '--vary KEY=DIST')
        if len(self.vary) > MAX_VARY:
            raise ParameterError(f'{len(self.vary)} --vary distributions: at most {MAX_VARY}')
        if not 0 <= self.seed <= MAX_SEED:
            raise ParameterError(f'--seed {self.seed}: must be an integer in [0, 2**64 - 1]')

    def _check_size(self):
        """Points and blocks bounded (Python integers: nothing allocated yet)."""
        if self.points > MAX_POINTS:
            raise ParameterError(f'{self.points} points (grid x samples): more than '
                                 f'{MAX_POINTS:.0e}; split the sweep')
        least = -(-self.points // MAX_BLOCKS)
        if self.block_points is not None and self.block_points < 1:
            raise ParameterError(f'--block {self.block_points}: must be >= 1')
        if self.block_points is None:
            object.__setattr__(self, 'block_points', least)
        if self.block_points > self.points:          # one block: the whole grid
            object.__setattr__(self, 'block_points', self.points)
        if self.block_points < least:
            raise ParameterError(f'--block {self.block_points}: {self.blocks} blocks, more than '
                                 f'{MAX_BLOCKS}; give --block {least} or more')

    def _check_draws(self):
        rows = [np.asarray(d, dtype=float) for d in self.draws]
        if len(rows) != len(self.vary) or any(r.shape != (self.samples,) for r in rows):
            raise ParameterError(f'the Monte Carlo draws are not {len(self.vary)} x '
                                 f'{self.samples} numbers')
        for dist, row in zip(self.vary, rows):
            if not np.isfinite(row).all():
                raise ParameterError(f'--vary {dist.text}: a draw is not a finite number '
                                     '(the parameters overflow)')

    # --- the grid -------------------------------------------------------------------
    @property
    def shape(self) -> tuple:
        """(ny, nx) or (ny, nx, samples); ny = 1 without a y axis."""
        grid = (self.y.size if self.y else 1, self.x.size)
        return grid + ((self.samples,) if self.samples else ())

    @property
    def points(self) -> int:
        return math.prod(self.shape)

    @property
    def blocks(self) -> int:
        return -(-self.points // self.block_points)

    def block_range(self, block: int) -> range:
        return range(block * self.block_points, min((block + 1) * self.block_points,
                                                     self.points))

    def values_at(self, flat: int) -> dict:
        """``{key: value}`` assigned at flat point index ``flat`` (row-major in ``shape``)."""
        index = np.unravel_index(flat, self.shape)
        values = {self.x.key: self.x.values[index[1]]}
        if self.y:
            values[self.y.key] = self.y.values[index[0]]
        if self.samples:
            for dist, draw in zip(self.vary, self.draws):
                values[dist.key] = draw[index[2]]
        return values

    def starts_line(self, flat: int) -> bool:
        """Whether ``flat`` begins a line along ``x`` (a linear sweep reseeds its roots)."""
        return bool(self.samples) or np.unravel_index(flat, self.shape)[1] == 0

    @property
    def outputs(self) -> tuple:
        return LINEAR_OUTPUTS if self.kind == 'linear' else tuple(self.stats)

    # --- storage --------------------------------------------------------------------
    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, text) -> SweepSpec:
        """The spec of :meth:`to_json` text; anything else is a :class:`ParameterError`."""
        try:
            data = load_json(text)
        except (ValueError, TypeError, RecursionError) as exc:
            raise ParameterError(f'not a sweep spec: not JSON ({_short(exc)})') from None
        return cls.from_dict(data)

    @classmethod
    def from_dict(cls, d) -> SweepSpec:
        """The spec of a mapping of :meth:`to_json` (every field, typed as written)."""
        if not isinstance(d, dict):
            raise ParameterError(f'not a sweep spec: a {type(d).__name__}, not a mapping')
        names = {f.name for f in fields(cls)}
        if set(d) != names:
            odd = sorted(str(k)[:40] for k in set(d) ^ names)
            raise ParameterError(f'not a sweep spec: fields {", ".join(odd[:5])} missing or '
                                 'unknown')
        return cls(
            raw=_typed(d['raw'], 'raw', dict), kind=_typed(d['kind'], 'kind', str),
            x=_axis(d['x'], 'x'), y=None if d['y'] is None else _axis(d['y'], 'y'),
            stats=tuple(_typed(s, 'a stat', str) for s in _typed(d['stats'], 'stats', list)),
            duration=_real(d['duration'], 'duration'), settle=_real(d['settle'], 'settle'),
            samples=_integer(d['samples'], 'samples'), seed=_integer(d['seed'], 'seed'),
            vary=tuple(_distribution(v) for v in _typed(d['vary'], 'vary', list)),
            threshold=_real(d['threshold'], 'threshold'),
            block_points=_integer(d['block_points'], 'block_points'),
            label=_typed(d['label'], 'label', str),
            draws=tuple(tuple(_real(v, 'a draw') for v in _typed(row, 'a row of draws', list))
                        for row in _typed(d['draws'], 'draws', list)))


# --- typed reading of a stored spec -----------------------------------------------------
def load_json(text):
    """``json.loads`` with integers of at most :data:`MAX_JSON_INT_DIGITS` digits (a longer
    one is a ``ValueError``: no number of a spec is one, and floats cannot hold it)."""
    return json.loads(text, parse_int=_json_int)


def _json_int(text: str) -> int:
    if len(text.lstrip('-')) > MAX_JSON_INT_DIGITS:
        raise ValueError(f'an integer of {len(text.lstrip("-"))} digits (at most '
                         f'{MAX_JSON_INT_DIGITS})')
    return int(text)


def _short(exc) -> str:
    return ' '.join(f'{type(exc).__name__}: {exc}'.split())[:120]


def _typed(value, name: str, kind: type):
    if not isinstance(value, kind) or (isinstance(value, bool) and kind is not bool):
        raise ParameterError(f'not a sweep spec: {name} is not a {kind.__name__}')
    return value


def _real(value, name: str) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ParameterError(f'not a sweep spec: {name} = {str(value)[:40]!r} is not a number')
    try:
        return float(value)
    except OverflowError:
        raise ParameterError(f'not a sweep spec: {name} is out of range') from None


def _integer(value, name: str) -> int:
    if not isinstance(value, int) or isinstance(value, bool):
        raise ParameterError(f'not a sweep spec: {name} = {str(value)[:40]!r} is not an '
                             'integer')
    return value


def _axis(axis, name: str) -> Axis:
    if not isinstance(axis, dict) or set(axis) != {'key', 'values'}:
        raise ParameterError(f'not a sweep spec: axis {name} is not {{key, values}}')
    values = _typed(axis['values'], f'axis {name} values', list)
    return Axis(_typed(axis['key'], f'axis {name} key', str),
                tuple(_real(v, f'a value of axis {name}') for v in values))


def _distribution(v) -> Distribution:
    if not isinstance(v, dict) or set(v) != {'key', 'kind', 'a', 'b'}:
        raise ParameterError('not a sweep spec: a distribution is not {key, kind, a, b}')
    return Distribution(_typed(v['key'], 'a distribution key', str),
                        _typed(v['kind'], 'a distribution kind', str), _real(v['a'], 'a'),
                        _real(v['b'], 'b'))


# --- the values a sweep assigns, through the configuration schema -----------------------
_MISSING = object()


def _lookup(cfg: dict, key: str):
    node = cfg
    for part in key.split('.'):
        if not isinstance(node, dict) or part not in node:
            return _MISSING
        node = node[part]
    return node


def _validated(raw: dict, key: str, value, where: str) -> dict:
    """The configuration with ``key`` = ``value``, validated by the schema; a key the
    configuration ignores (one of another model type) is refused too."""
    try:
        cfg = validate(with_values(raw, {key: value}), where, {key: where})
    except ConfigError as exc:
        message = str(exc)
        raise ConfigError(message if message.startswith(where) else f'{where}: {message}') \
            from None
    if _lookup(cfg, key) is _MISSING:
        model = _lookup(cfg, 'model.type')
        raise ConfigError(f'{where}: does not apply to this configuration (model.type '
                          f'{model}): the sweep would not vary it')
    return cfg


def _check_values(raw: dict, key: str, values, where: str) -> None:
    """Every value of ``values`` valid for ``key``: a number key's range is an interval,
    so its extremes decide; an integer key (the schema returns an int) also needs every
    value whole."""
    cfg = _validated(raw, key, min(values), where)
    _validated(raw, key, max(values), where)
    if isinstance(_lookup(cfg, key), int):
        bad = next((v for v in values if not float(v).is_integer()), None)
        if bad is not None:
            _validated(raw, key, bad, where)     # the schema's own message


def _check_upsilon(kind: str, values, where: str) -> None:
    if kind != 'linear':
        raise ParameterError(f'{where}: upsilon_o is an axis of linear sweeps only: sweep '
                             'operating_point.weight_on_bit_N or groups.W_o instead')
    if min(values) < 0:
        raise ParameterError(f'{where}: upsilon_o = {min(values):g}: must be >= 0 (a '
                             'dimensionless penetration rate)')


def _check_effect(kind: str, key: str, where: str) -> None:
    """Keys the sweep itself sets or never reads: varying them would change nothing."""
    if kind == 'linear' and key.startswith('simulation.'):
        raise ParameterError(f'{where}: a linear sweep does not simulate, so simulation.* '
                             'keys change nothing')
    if key in DURATION_KEYS:
        raise ParameterError(f'{where}: the simulated time of a sweep is --duration')


def _assignments(spec: SweepSpec) -> list:
    """``(key, values, where)`` of every key the sweep sets at its points."""
    out = [(spec.x.key, spec.x.values, f'--x {spec.x.key}')]
    if spec.y is not None:
        out.append((spec.y.key, spec.y.values, f'--y {spec.y.key}'))
    out += [(d.key, draws, f'--vary {d.text}, a draw') for d, draws in zip(spec.vary,
                                                                           spec.draws)]
    return out


def _check_assignments(spec: SweepSpec) -> None:
    validate(spec.raw, 'the sweep configuration')      # (a stored spec's may be anything)
    assigned = _assignments(spec)
    keys = [key for key, _, _ in assigned]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise ParameterError(f'{", ".join(repeated)}: swept more than once (--x, --y and '
                             '--vary need different keys)')
    if UPSILON_O in keys and set(keys) & set(WOB_KEYS):
        raise ParameterError(f'upsilon_o sets the weight on bit: it cannot be swept with '
                             f'{", ".join(sorted(set(keys) & set(WOB_KEYS)))}')
    for key, values, where in assigned:
        if key == UPSILON_O:
            _check_upsilon(spec.kind, values, where)
            continue
        _check_effect(spec.kind, key, where)
        _check_values(spec.raw, key, values, where)
    if spec.kind == 'nonlinear':
        _check_duration(spec, assigned)


def _check_duration(spec: SweepSpec, assigned) -> None:
    """``duration`` through the schema's simulated-time key; the rows one point records
    bounded (:data:`MAX_ROWS_PER_POINT`)."""
    si = spec.raw.get('units') == 'si'
    suffix = '_s' if si else ''
    _validated(spec.raw, f'simulation.duration{suffix}', spec.duration,
               f'--duration {spec.duration:g}')
    record_key = f'simulation.record_interval{suffix}'
    record = _lookup(spec.raw, record_key)
    intervals = [DEFAULT_RECORD_INTERVAL if record is _MISSING else float(record)]
    intervals += [min(values) for key, values, _ in assigned if key == record_key]
    rows = spec.duration / min(intervals)
    if rows > MAX_ROWS_PER_POINT:
        unit = 's' if si else 't*'
        raise ParameterError(f'--duration {spec.duration:g} {unit} recorded every '
                             f'{min(intervals):g} {unit} is {rows:.3g} rows per point (more '
                             f'than {MAX_ROWS_PER_POINT:.0e}): raise {record_key} (--set)')
