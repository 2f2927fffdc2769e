"""Fuzz targets of the sweep's parsers: the command line's strings and numbers (axes
``KEY:MIN:MAX:N``, ``--vary KEY=DIST(A,B)``, ``--stat``, the kind, times, samples, seed,
threshold, block) turned into a :class:`~drill_twin.sweep.spec.SweepSpec`
(:func:`drill_twin.sweep.cli.spec_from_args`), and what a resumed sweep reads: the bytes
of a ``spec.json`` (:func:`drill_twin.sweep.store.parse_stored`) and of block files
(:meth:`SweepStore.scan`).  Whatever they are given, they return or raise the project's
user error (:class:`~drill_twin.errors.ParameterError`: one line, exit code 2
on the command line), never anything else; a spec they accept reads back from its own
JSON as the same spec.  Parse only: nothing is evaluated.

Each target runs 10,000 examples (``hypothesis``); the inputs mix random text and bytes
with the schema's keys, the statistics' names and valid specs with one field replaced,
so that most examples get past the syntax into the checks behind it.
"""
import argparse
import io
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drill_twin.config.scenario import load_scenario
from drill_twin.config.schema import SCHEMA
from drill_twin.errors import ParameterError
from drill_twin.sweep import SweepSpec, SweepStore, parse_axis, parse_distribution
from drill_twin.sweep.cli import spec_from_args
from drill_twin.sweep.spec import DISTRIBUTIONS, NONLINEAR_STATS
from drill_twin.sweep.store import parse_stored

pytestmark = pytest.mark.slow

#: examples of the spec targets (DRILL_TWIN_FUZZ_EXAMPLES to try fewer while editing)
EXAMPLES = int(os.environ.get('DRILL_TWIN_FUZZ_EXAMPLES', 10_000))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])
#: longest error line accepted [characters]: a path, a key, a value cut short, the rule
LONGEST_LINE = 600
SCENARIOS = {name: load_scenario(name) for name in ('rgd_stick_slip', 'benchmark_fem')}


def _dotted(section, path=''):
    for key in section.keys:
        yield f'{path}{key.name}'
    for sub in section.subsections:
        yield from _dotted(sub, f'{path}{sub.name}.')


KEYS = sorted(set(_dotted(SCHEMA)) | {'upsilon_o'})
#: keys as a command line may write them: the schema's, near misses, nonsense
KEY = st.sampled_from(KEYS + [k + '.x' for k in KEYS[:20]] + [k.upper() for k in KEYS[:20]] +
                      [k[:-1] for k in KEYS[:20]] + ['', ' ', '.', 'a..b', 'nope.key',
                                                     'groups', 'model', 'a' * 300,
                                                     '.'.join('abcdefghijk'), 'é.ß'])
#: numbers as a command line writes them, and text float() / int() may or may not read
ODD_NUMBERS = ['nan', 'inf', '-inf', '1e308', '-1e308', '1e400', '-0', '1_0', '0x10', '',
               ' ', '1e-320', '5e4', '9' * 40, '٣', '1,5', '0', '1', '2', '3', '0.5', '7',
               '-1', '100', '1e4', '1e6', 'x', '1e', '+5', ' 2 ']
PLAIN_NUMBERS = ['0', '0.05', '0.2', '0.5', '1', '2', '3', '4', '5', '7', '8', '10', '12',
                 '40', '100', '5.5e4', '9e4']
NUMBER = st.one_of(st.sampled_from(PLAIN_NUMBERS), st.sampled_from(PLAIN_NUMBERS),
                   st.sampled_from(ODD_NUMBERS),
                   st.floats(allow_nan=True, allow_infinity=True).map(repr),
                   st.integers(min_value=-10 ** 25, max_value=10 ** 25).map(str))
COUNT = st.one_of(st.integers(min_value=1, max_value=6).map(str),
                  st.integers(min_value=-2, max_value=6).map(str),
                  st.sampled_from(['100001', '1000000000', '1e3', '2.0', ' 3 ', '',
                                   '9' * 30, '-0']))
SEP = st.sampled_from([':'] * 12 + ['::', ' : ', ';', ''])
TEXT = st.text(alphabet=':=(),.-+e0123456789 abcnuif_\n\x00é', max_size=20)
#: (hypothesis favours the first choices of a sampled list: the rare one is last)
RARELY = st.sampled_from([False] * 9 + [True])
AXES = st.builds(lambda k, a, b, n, s: s.join([k, a, b, n]), KEY, NUMBER, NUMBER, COUNT, SEP)
#: axes of the keys the shipped configurations sweep, plain numbers: mostly accepted
PLAIN_AXES = st.builds(
    lambda k, bounds, n: f'{k}:{bounds[0]}:{bounds[1]}:{n}', st.sampled_from(
        ['groups.omega_o', 'groups.W_o', 'groups.beta', 'groups.psi', 'groups.n_b',
         'upsilon_o', 'operating_point.surface_speed_rad_s', 'operating_point.weight_on_bit_N',
         'drill_string.pipe_length_m', 'simulation.record_interval', 'model.elements']),
    st.lists(st.sampled_from(PLAIN_NUMBERS), min_size=2, max_size=2, unique=True).map(
        lambda pair: sorted(pair, key=float)),
    st.integers(min_value=2, max_value=6))
AXIS = st.one_of(PLAIN_AXES, PLAIN_AXES, AXES, TEXT)
DISTS = st.builds(lambda k, d, a, b, eq: f'{k}{eq}{d}({a},{b})', KEY,
                  st.sampled_from(DISTRIBUTIONS * 3 + ('gauss', '', 'Uniform', 'normal ')),
                  NUMBER, NUMBER, st.sampled_from(['='] * 6 + [' = ', '==', '']))
PLAIN_DISTS = st.builds(lambda k, d, a, b: f'{k}={d}({a},{b})', st.sampled_from(
    ['groups.beta', 'groups.psi', 'groups.kappa_d', 'drill_string.bit_radius_m',
     'drill_string.friction_coefficient_mu', 'operating_point.weight_on_bit_N']),
    st.sampled_from(DISTRIBUTIONS), st.sampled_from(PLAIN_NUMBERS),
    st.sampled_from(PLAIN_NUMBERS))
DIST = st.one_of(PLAIN_DISTS, PLAIN_DISTS, DISTS, TEXT)
STATS = st.one_of(st.none(), st.lists(st.sampled_from(NONLINEAR_STATS + ('', 'speed', 'severty')),
                                      max_size=3))
REAL = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True),
                 st.sampled_from([0.0, 1.0, 10.0, 40.0, 1e6, 1e30]))
INT = st.one_of(st.integers(min_value=-2, max_value=10),
                st.integers(min_value=-10 ** 30, max_value=10 ** 30))


def _user_error_only(call):
    """Run ``call``: what it returns, or a short one-line user error."""
    try:
        return call()
    except ParameterError as exc:
        line = ' '.join(str(exc).split())
        assert line and len(line) <= LONGEST_LINE, line[:2000]
    return None


# --- the command line --------------------------------------------------------------------

#: the other options of a command line (made once: a strategy made per example is checked
#: per example)
CONFIG = st.sampled_from(sorted(SCENARIOS))
KIND = st.sampled_from(['linear', 'nonlinear'])
MAYBE_AXIS = st.none() | AXIS
VARY = st.lists(DIST, max_size=2)
SAMPLES = st.integers(min_value=1, max_value=6) | INT
SEED = st.none() | INT
BLOCK = st.one_of(st.none(), st.integers(min_value=1, max_value=50),
                  st.sampled_from([None, 1, 4]), INT)


@st.composite
def _command_line(draw) -> argparse.Namespace:
    """The options of a sweep command line, typed as argparse gives them; the options of
    the other kind of sweep (refused at once) only now and then, so that most examples
    reach the checks of the axes, the distributions and the statistics."""
    kind, odd, monte_carlo = draw(KIND), draw(RARELY), draw(st.booleans())
    linear = kind == 'linear'
    return argparse.Namespace(
        config=draw(CONFIG), set=[], kind=kind, x=draw(AXIS), y=draw(MAYBE_AXIS),
        stat=draw(STATS) if not linear or odd else None,
        duration=draw(REAL) if not linear or odd else None,
        settle=draw(REAL) if not linear or odd else None,
        threshold=draw(REAL) if linear or odd else None,
        samples=draw(SAMPLES) if monte_carlo or odd else 0,
        vary=draw(VARY) if monte_carlo or odd else [],
        seed=draw(SEED) if monte_carlo or odd else None,
        block=draw(BLOCK))


@FUZZ
@given(_command_line())
def test_command_line_strings_give_a_spec_or_a_user_error(monkeypatch_module, args):
    """A sweep command line's options to a spec; an accepted spec reads back from its JSON
    as the same spec."""
    spec = _user_error_only(lambda: spec_from_args(args, args.block))
    if spec is not None:
        assert SweepSpec.from_json(spec.to_json()) == spec


@pytest.fixture(scope='module')
def monkeypatch_module():
    """The configurations loaded once (the target fuzzes the sweep's parsing, not YAML's)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr('drill_twin.config.scenario.load_scenario',
                   lambda name, overrides=(), label='--set': SCENARIOS[name])
        yield mp


# --- what a resumed sweep reads ---------------------------------------------------------

def _stored(spec: SweepSpec, runs: int = 1) -> dict:
    return {'spec': json.loads(spec.to_json()), 'runs': runs}


RGD = SCENARIOS['rgd_stick_slip'].raw
GOOD_SPECS = [
    SweepSpec(RGD, 'linear', parse_axis('groups.omega_o:1:40:5'), parse_axis('upsilon_o:0:4:3'),
              block_points=4),
    SweepSpec(RGD, 'nonlinear', parse_axis('groups.omega_o:3:12:3'), duration=40.0,
              settle=20.0, samples=4, seed=7, block_points=3,
              vary=(parse_distribution('groups.beta=uniform(0.2,0.5)'),)),
]
SPEC_FIELDS = sorted(_stored(GOOD_SPECS[0])['spec'])
#: JSON values a spec field may be replaced with: odd scalars, the names a spec holds,
#: containers empty, nested, or of the wrong kind
JSON_VALUES = st.one_of(
    st.sampled_from([None, True, False, 0, 1, -1, 3, 2 ** 64, -(10 ** 30), 10 ** 400, 0.5,
                     -2.5, 1e308, float('nan'), float('inf'), '', 'x', '1.0', 'linear',
                     'nonlinear', 'uniform', [], {}, [1.0], [[]], [[1.0, 'x']], {'key': 'x'},
                     {'key': 'groups.beta', 'values': []}, [None], [float('nan')],
                     {'units': 'si'}, [[[[[]]]]]] + KEYS + list(NONLINEAR_STATS)),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10 ** 20, max_value=10 ** 20))


@st.composite
def _mutated_spec(draw) -> bytes:
    """A valid spec.json with a field replaced, removed or added (in the spec, in an axis,
    in a distribution or in the configuration), then perhaps cut short."""
    stored = _stored(draw(st.sampled_from(GOOD_SPECS)), draw(st.sampled_from([0, 1, 3])))
    where = draw(st.sampled_from(['top', 'spec', 'x', 'vary', 'raw', 'groups']))
    node = {'top': stored, 'spec': stored['spec'], 'x': stored['spec']['x'],
            'vary': (stored['spec']['vary'] or [{}])[0], 'raw': stored['spec']['raw'],
            'groups': stored['spec']['raw']['groups']}[where]
    name = draw(st.sampled_from(sorted(node) or ['runs']) | st.text(max_size=4))
    action = draw(st.sampled_from(['replace', 'remove', 'replace']))
    if action == 'remove':
        node.pop(name, None)
    else:
        node[name] = draw(JSON_VALUES)
    data = json.dumps(stored).encode()
    cut = draw(st.integers(min_value=0, max_value=len(data)))
    return data[:cut] if draw(RARELY) else data


@FUZZ
@given(st.one_of(_mutated_spec(), st.binary(max_size=300),
                 JSON_VALUES.map(lambda v: json.dumps(v).encode()),
                 st.sampled_from([b'[' * 100_000, b'{"spec": ' * 20_000, b'9' * 5000]),
                 st.text(max_size=100).map(lambda t: t.encode('utf-8', 'surrogatepass'))))
def test_spec_json_bytes_give_a_spec_or_a_user_error(data):
    """The bytes of a spec.json, mostly valid ones with one field changed."""
    stored = _user_error_only(lambda: parse_stored(data, 'OUT/spec.json'))
    if stored is not None:
        spec, runs = stored
        assert isinstance(runs, int) and runs >= 0
        assert SweepSpec.from_json(spec.to_json()) == spec


SCRATCH = Path(tempfile.mkdtemp(prefix='drill_twin_fuzz_sweep_'))


def _good_block() -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, run=np.int32(1), compute_s=0.1, abscissa=np.linspace(0, 1, 4),
             unstable=np.arange(4, dtype=np.int32))
    return buffer.getvalue()


GOOD_BLOCK = _good_block()


@st.composite
def _mutated_block(draw) -> bytes:
    """A good block file with bytes overwritten, or cut short."""
    data = bytearray(GOOD_BLOCK)
    for _ in range(draw(st.integers(min_value=0, max_value=4))):
        at = draw(st.integers(min_value=0, max_value=len(data) - 1))
        data[at:at + 4] = draw(st.binary(min_size=1, max_size=4))
    cut = draw(st.none() | st.integers(min_value=0, max_value=len(data)))
    return bytes(data if cut is None else data[:cut])


_STORE = []


def _store() -> SweepStore:
    """The scratch sweep directory of the block target (made once, one run begun)."""
    if not _STORE:
        _STORE.append(SweepStore(SCRATCH / 'sweep', GOOD_SPECS[0]))
        _STORE[0].begin_run()
    return _STORE[0]


#: the block target's examples: fewer (each writes a file and opens it as a zip archive)
BLOCK_FUZZ = settings(FUZZ, max_examples=max(1, EXAMPLES // 10))


@BLOCK_FUZZ
@given(st.one_of(_mutated_block(), st.binary(max_size=400)))
def test_block_file_bytes_are_a_block_or_reported(data):
    """A resumed sweep's block file, any bytes: a finished block, or one reported line."""
    store = _store()
    (store.blocks_dir / '000000.npz').write_bytes(data)
    done, problems = store.scan()
    assert (0 in done) != bool(problems) and len(problems) <= 1


def teardown_module():
    shutil.rmtree(SCRATCH, ignore_errors=True)
