"""What a sweep computes, as plain data: the configuration, the grid axes, the kind, the
statistics, the Monte Carlo distributions and the blocks the grid is cut into.

A :class:`SweepSpec` is JSON-serialisable (``to_json`` / ``from_json``): it is stored
beside the results so that an interrupted sweep resumes on exactly the same points and
blocks, and it is what every Dask task receives.  Monte Carlo samples are drawn once,
here, from a seeded generator: every worker and every resumption sees the same numbers.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass

import numpy as np

from ..physics.parameters import ParameterError

__all__ = ['Axis', 'Distribution', 'SweepSpec', 'parse_axis', 'parse_distribution',
           'KINDS', 'LINEAR_OUTPUTS', 'NONLINEAR_STATS', 'DEFAULT_STATS']

KINDS = ('linear', 'nonlinear')
#: what a linear sweep stores per point
LINEAR_OUTPUTS = ('abscissa', 'unstable')
#: statistics of ``drill-twin simulate --summary-json`` a nonlinear sweep can store
NONLINEAR_STATS = ('severity', 'stick_fraction', 'bit_speed_max', 'bit_speed_min',
                   'bit_speed_mean', 'rop_mean', 'first_angular_stick', 'delay_residual_max')
DEFAULT_STATS = ('severity', 'stick_fraction', 'rop_mean')
#: most points one sweep holds (its result arrays live in memory when assembled)
MAX_POINTS = 10_000_000


@dataclass(frozen=True)
class Axis:
    """A grid axis: a dotted configuration key (or ``upsilon_o``) and its values."""

    key: str
    values: tuple

    @property
    def size(self) -> int:
        return len(self.values)


def parse_axis(text: str) -> Axis:
    """``KEY:MIN:MAX:N`` → :class:`Axis` (N ≥ 2 evenly spaced values, or N = 1 at MIN)."""
    try:
        key, lo, hi, n = text.rsplit(':', 3)
        lo, hi, n = float(lo), float(hi), int(n)
    except ValueError:
        raise ParameterError(f'axis {text!r} is not KEY:MIN:MAX:N') from None
    if not key or n < 1 or not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f'axis {text!r} needs a key, N >= 1 and finite bounds')
    return Axis(key, tuple(float(v) for v in np.linspace(lo, hi, n)))


@dataclass(frozen=True)
class Distribution:
    """A Monte Carlo distribution of one configuration key.

    ``uniform(low, high)``; ``normal(mean, std)``; ``lognormal(median, sigma)`` (the
    logarithm is normal with mean ln(median) and standard deviation sigma).
    """

    key: str
    kind: str
    a: float
    b: float

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        if self.kind == 'uniform':
            return rng.uniform(self.a, self.b, n)
        if self.kind == 'normal':
            return rng.normal(self.a, self.b, n)
        return rng.lognormal(math.log(self.a), self.b, n)


_DIST = re.compile(r'^\s*([\w.]+)\s*=\s*(uniform|normal|lognormal)\s*\(\s*([^,()]+)\s*,'
                   r'\s*([^,()]+)\s*\)\s*$')


def parse_distribution(text: str) -> Distribution:
    """``KEY=uniform(LOW,HIGH)`` | ``KEY=normal(MEAN,STD)`` | ``KEY=lognormal(MEDIAN,SIGMA)``."""
    m = _DIST.match(text)
    if not m:
        raise ParameterError(f'--vary {text!r}: not KEY=uniform(LOW,HIGH), KEY=normal(MEAN,STD) '
                             'or KEY=lognormal(MEDIAN,SIGMA)')
    key, kind = m.group(1), m.group(2)
    try:
        a, b = float(m.group(3)), float(m.group(4))
    except ValueError:
        raise ParameterError(f'--vary {text!r}: the parameters are not numbers') from None
    ok = math.isfinite(a) and math.isfinite(b) and {
        'uniform': a < b, 'normal': b > 0, 'lognormal': a > 0 and b > 0}[kind]
    if not ok:
        raise ParameterError(f'--vary {text!r}: needs LOW < HIGH (uniform), STD > 0 (normal), '
                             'MEDIAN > 0 and SIGMA > 0 (lognormal)')
    return Distribution(key, kind, a, b)


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
    block_points : int
        Points per Dask task (consecutive along ``x``, then ``y``, then the sample).
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
    block_points: int = 1
    label: str = ''
    draws: tuple = ()

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ParameterError(f'--kind {self.kind!r}: one of {", ".join(KINDS)}')
        if self.kind == 'nonlinear':
            unknown = [s for s in self.stats if s not in NONLINEAR_STATS]
            if unknown or not self.stats:
                raise ParameterError(f'--stat {",".join(unknown) or "(none)"}: not a statistic '
                                     f'of simulate --summary-json ({", ".join(NONLINEAR_STATS)})')
            if not (self.duration > 0 and 0 <= self.settle < self.duration):
                raise ParameterError(f'a nonlinear sweep needs duration > 0 and 0 <= settle < '
                                     f'duration, got {self.duration:g}, {self.settle:g}')
        if self.samples < 0 or (self.samples > 0) != bool(self.vary):
            raise ParameterError('Monte Carlo needs both --samples N (N >= 1) and at least one '
                                 '--vary KEY=DIST')
        if self.block_points < 1:
            raise ParameterError(f'block of {self.block_points} points: must be >= 1')
        if self.seed < 0 or not math.isfinite(self.threshold):
            raise ParameterError(f'--seed {self.seed} must be >= 0 and --threshold '
                                 f'{self.threshold:g} finite')
        if self.points > MAX_POINTS:
            raise ParameterError(f'{self.points} points (grid x samples): more than '
                                 f'{MAX_POINTS:.0e}; split the sweep')
        if self.vary and not self.draws:
            rng = np.random.default_rng(self.seed)
            draws = tuple(tuple(float(v) for v in d.draw(rng, self.samples)) for d in self.vary)
            object.__setattr__(self, 'draws', draws)

    # --- the grid -------------------------------------------------------------------
    @property
    def shape(self) -> tuple:
        """(ny, nx) or (ny, nx, samples); ny = 1 without a y axis."""
        grid = (self.y.size if self.y else 1, self.x.size)
        return grid + ((self.samples,) if self.samples else ())

    @property
    def points(self) -> int:
        return int(np.prod(self.shape))

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
    def from_json(cls, text: str) -> SweepSpec:
        d = json.loads(text)
        d['x'] = Axis(d['x']['key'], tuple(d['x']['values']))
        d['y'] = Axis(d['y']['key'], tuple(d['y']['values'])) if d['y'] else None
        d['vary'] = tuple(Distribution(**v) for v in d['vary'])
        d['stats'] = tuple(d['stats'])
        d['draws'] = tuple(tuple(v) for v in d['draws'])
        return cls(**d)
