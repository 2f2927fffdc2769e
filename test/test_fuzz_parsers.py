"""Fuzz targets of the parsers of user input: the configuration parser (YAML text ->
configuration, ``--set KEY=VALUE``), the scenario parser (YAML text -> timeline) and the
MCAP reader (mutated bytes of a small good recording).  Whatever they are given, they
return or raise one of the project's user errors (one line, exit code 2 on the command
line), never anything else.  Parse only: nothing is simulated.

Each target runs 10,000 examples (``hypothesis``); the generated inputs mix random text
with YAML's tokens and the schema's own keys and values, so that most examples get past
the YAML layer into the checks behind it.
"""
import atexit
import math
import os
import shutil
import struct
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from drill_twin.config.lookup import CONFIG_DIR
from drill_twin.config.scenario import apply_overrides, load_scenario, read_config, with_values
from drill_twin.config.schema import _LEGACY_GEOMETRY as LEGACY_GEOMETRY
from drill_twin.config.schema import SCHEMA, validate
from drill_twin.errors import ParameterError
from drill_twin.io.mcap_reader import RecordingError, check_decodable, open_recording
from drill_twin.operations.timeline import ACTIONS, load_timeline

pytestmark = pytest.mark.slow

#: the project's user errors (drill_twin.cli.USER_ERRORS less OSError: a parser given a
#: path it can read raises no OSError)
USER_ERRORS = (ParameterError, RecordingError)
#: examples per target (DRILL_TWIN_FUZZ_EXAMPLES to try fewer while editing)
EXAMPLES = int(os.environ.get('DRILL_TWIN_FUZZ_EXAMPLES', 10_000))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])
SCRATCH = Path(tempfile.mkdtemp(prefix='drill_twin_fuzz_'))
atexit.register(shutil.rmtree, SCRATCH, True)
CONFIGS = {path.stem: read_config(path) for path in sorted(CONFIG_DIR.glob('*.yaml'))}
CONFIG_TEXTS = [path.read_text() for path in sorted(CONFIG_DIR.glob('*.yaml'))]
SCENARIO_TEXTS = [path.read_text() for path in sorted((CONFIG_DIR / 'operations').glob('*.yaml'))]
BENCH = CONFIGS['benchmark_fem']


def _keys(section, units, path=''):
    """``{dotted key: Key}`` of the keys that apply to ``units`` (lists of sections
    excluded: edited whole)."""
    out = {}
    if section.units and units not in section.units:
        return out
    for key in section.keys:
        out[f'{path}{key.name}'] = key
    for sub in section.subsections:
        if not sub.many:
            out.update(_keys(sub, units, f'{path}{sub.name}.'))
    return out


KEYS = {units: _keys(SCHEMA, units) for units in ('si', 'dimensionless')}
WORDS = sorted({part for keys in KEYS.values() for key in keys for part in key.split('.')} |
               {'si', 'dimensionless', 'fem', 'rgd', 'rgd_k', 'hoist', 'motor', 'speed',
                'auto', 'smooth', 'bit', 'sections', 'name'})
#: YAML's syntax, tags, anchors and the scalars its resolvers treat specially
TOKENS = ['{', '}', '[', ']', ',', ': ', ':', '- ', '\n', '  ', '    ', '&a ', '*a', '&b ',
          '*b', '<<: ', '? ', '|\n', '>\n', '"', "'", '# c', '---\n', '...\n', '%YAML 1.1\n',
          '!!int ', '!!float ', '!!str ', '!!bool ', '!!null ', '!!timestamp ', '!!binary ',
          '!!set ', '!!omap ', '!!pairs ', '!!map ', '!!seq ', '!!merge ', '!foo ',
          '!!python/object:os.system ', '.nan', '.inf', '-.inf', '1e400', '9' * 400,
          '0x' + 'f' * 30, '0b1011', '0o17', '017', '1:30:00', '9' * 30 + ':30.5',
          '2001-02-30', '2001-12-14t21:59:43.10-05:00', 'true', 'no', 'null', '~', '5e-3',
          '-1', '0', '58', '2.5', '1_000', '\t', '\x85', '\ufeff', '\x07', '%', '@', '`',
          '[' * 40, '&a [*a]', '&a [1, 2]\nb: [*a, *a, *a, *a]']
#: text without control characters (which the YAML reader refuses at once)
TEXT = st.text(st.characters(blacklist_categories=('Cc', 'Cs')), max_size=6)
SCALARS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10 ** 25, max_value=10 ** 25),
    st.integers(min_value=1, max_value=128),
    st.booleans(), st.none(), TEXT,
    st.sampled_from(WORDS + ['5e-3', '.nan', '1e400', '-0', 'nan', 'inf']))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(WORDS) | TEXT, inner,
                                                 max_size=4)), max_leaves=8)
YAMLISH = st.lists(st.one_of(st.sampled_from(TOKENS), st.sampled_from(WORDS), TEXT),
                   max_size=40).map(''.join)


@st.composite
def spliced(draw, texts):
    """One of ``texts`` with up to three pieces of YAML-ish text written over it."""
    text = draw(st.sampled_from(texts))
    for _ in range(draw(st.integers(1, 3))):
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(YAMLISH) + text[at + draw(st.integers(0, 12)):]
    return text


def _in_range(key):
    """Values of ``key`` inside its range, log-spread (what gets past the schema into the
    physical checks), or one of its choices."""
    if key.choices:
        return st.sampled_from(key.choices)
    if key.kind == 'bool':
        return st.booleans()
    low = key.low if key.low is not None and key.low > 0 else 1e-6
    high = key.high if key.high is not None else 1e6
    if key.kind == 'int':
        return st.integers(max(1, int(low)), max(1, min(int(high), 128)))
    number = st.floats(math.log10(low), math.log10(high)).map(lambda e: 10.0 ** e)
    return st.lists(number, min_size=1, max_size=8) if key.kind == 'float_list' else number


SECTION = st.fixed_dictionaries(
    {'name': TEXT, 'length_m': st.floats(1, 2000), 'outer_diameter_m': st.floats(0.05, 0.3),
     'inner_diameter_m': st.floats(0, 0.3)},
    optional={'bha': st.booleans(), 'elements': st.integers(1, 40) | VALUES,
              'density_kg_m3': st.floats(1000, 9000) | VALUES, 'what': VALUES})


#: strategies built once (building one per draw costs more than the draw)
IN_RANGE = {units: {name: _in_range(key) for name, key in keys.items()}
            for units, keys in KEYS.items()}
NAMES = {units: st.sampled_from(sorted(keys)) | st.sampled_from(WORDS)
         for units, keys in KEYS.items()}


@st.composite
def edits(draw):
    """A shipped configuration's name and ``{dotted key: value}`` edits: values in range
    mostly, else hostile ones (NaN, infinities, 25-digit integers, text, nested lists)."""
    name = draw(st.sampled_from(sorted(CONFIGS)))
    units = CONFIGS[name]['units']
    out = {}
    for _ in range(draw(st.integers(1, 4))):
        dotted = draw(NAMES[units])
        if dotted in IN_RANGE[units] and draw(st.integers(0, 9)) < 7:
            out[dotted] = draw(IN_RANGE[units][dotted])
        else:
            out[dotted] = draw(VALUES)
    if CONFIGS[name]['units'] == 'si' and draw(st.integers(0, 9)) == 0:
        out['drill_string.sections'] = draw(st.lists(SECTION, min_size=1, max_size=3) |
                                            VALUES)
    return name, out


def _file(data, name='input.yaml') -> Path:
    """``data`` written to the scratch file ``name`` (one per target, rewritten)."""
    path = SCRATCH / name
    if isinstance(data, str):
        data = data.encode('utf-8', 'surrogatepass')
    path.write_bytes(data)
    return path


def _dump(value) -> str:
    return yaml.dump(value, Dumper=getattr(yaml, 'CSafeDumper', yaml.SafeDumper),
                     allow_unicode=True, sort_keys=False)


#: longest error line accepted [characters]: a path, a key, a value cut short, the rule
LONGEST_LINE = 600


def _user_error_only(call):
    """Run ``call``: it may raise a user error only, whose text (one line once the
    command line joins its whitespace, as for an input with newlines) is short."""
    try:
        call()
    except USER_ERRORS as exc:
        line = ' '.join(str(exc).split())
        assert line and len(line) <= LONGEST_LINE, line[:2000]


# --- configurations -------------------------------------------------------------------

@FUZZ
@given(st.one_of(spliced(CONFIG_TEXTS), YAMLISH, st.text(max_size=200)))
def test_configuration_text_gives_a_configuration_or_a_user_error(text):
    """Any text as a configuration file, mostly a shipped one with YAML-ish pieces
    written over it: read and validated against the schema."""
    path = _file(text)
    _user_error_only(lambda: validate(read_config(path), str(path)))


@FUZZ
@given(edits())
def test_edited_configurations_load_or_give_a_user_error(edit):
    """A shipped configuration with values replaced, written as YAML and loaded to a
    model (no time step check: nothing integrates)."""
    name, values = edit
    try:
        raw = with_values(CONFIGS[name], values)
    except ParameterError:        # a key below a value that is not a section
        return
    if 'drill_string.sections' in values:    # the sections replace the two-section keys
        for key in LEGACY_GEOMETRY:
            raw['drill_string'].pop(key, None)
    assume(_quick(raw))
    path = _file(_dump(raw))
    _user_error_only(lambda: load_scenario(path, check_step=False))


#: most finite elements or oscillators a parse-only test builds (a model's set-up grows
#: as n^3: 1,000 elements take 15 s)
SMALL = 128


def _quick(value) -> bool:
    """No count of elements or oscillators above :data:`SMALL` anywhere in ``value``."""
    if isinstance(value, dict):
        return all(_quick(v) and not (k in ('elements', 'bha_elements', 'n') and
                                      _large(v)) for k, v in value.items())
    if isinstance(value, list):
        return all(_quick(v) for v in value)
    return True


def _large(value) -> bool:
    try:
        return float(value) > SMALL
    except (TypeError, ValueError, OverflowError):
        return False


@FUZZ
@given(st.one_of(st.sampled_from(sorted(KEYS['si'])), st.sampled_from(WORDS), TEXT,
                 st.text(max_size=12)),
       st.one_of(YAMLISH, VALUES.map(lambda v: _dump(v).strip()), st.text(max_size=30)),
       st.sampled_from(['=', '=', '=', ' = ', '==', '']))
def test_set_strings_give_a_configuration_or_a_user_error(key, value, sign):
    """``--set KEY=VALUE`` strings on the benchmark: applied and validated."""
    item = f'{key}{sign}{value}'
    _user_error_only(lambda: validate(apply_overrides(BENCH, [item]), 'benchmark'))


# --- scenarios --------------------------------------------------------------------------

def _step_params(action):
    spec = ACTIONS[action]
    in_range = st.fixed_dictionaries({}, optional={
        name: st.floats(low, high) for name, (_, low, high, _) in spec.items()})
    return st.one_of(in_range, in_range, st.none(), SCALARS, st.dictionaries(
        st.sampled_from(sorted(spec) or ['x']) | TEXT, SCALARS, max_size=3))


STEP = st.one_of(*(st.builds(lambda a, p: {a: p}, st.just(a), _step_params(a))
                   for a in sorted(ACTIONS)),
                 st.dictionaries(TEXT, SCALARS, max_size=2), SCALARS)
SCENARIO = st.fixed_dictionaries(
    {'configuration': st.sampled_from(['benchmark_fem', 'benchmark_fem', 'rig_fem',
                                       'rgd_stick_slip', 'no_such', 5]),
     'steps': st.lists(STEP, min_size=1, max_size=5) | SCALARS},
    optional={'overrides': st.lists(st.sampled_from(
                  ['model.axial_top=hoist', 'model.axial_top=hoist', 'model.axial_top=velocity',
                   'model.elements=x', 'x', 'drill_string.density_kg_m3=1000',
                   'drill_string.mud_density_kg_m3=2900']), max_size=2) | SCALARS,
              'start': st.sampled_from(['rest', 'drilling', 'drilling', 'sprint', None]),
              'rate_hz': st.floats(1, 1000) | SCALARS,
              'bit_above_bottom_m': st.floats(1e-3, 100) | SCALARS,
              'description': TEXT | VALUES})
#: keys a scenario does not take, added now and then
JUNK = st.dictionaries(st.sampled_from(['duration_s', 'stepz', 'rate', 'duration']), SCALARS,
                       max_size=1)


@FUZZ
@given(st.one_of(st.builds(lambda a, b: {**a, **b}, SCENARIO, JUNK).map(_dump),
                 spliced(SCENARIO_TEXTS), YAMLISH))
def test_scenario_text_gives_a_timeline_or_a_user_error(text):
    """Any text as a scenario file, mostly near-valid ones: parsed and checked against
    its configuration (loaded, not run)."""
    path = _file(text)
    _user_error_only(lambda: load_timeline(path))


# --- recordings ---------------------------------------------------------------------------

def _good_recording() -> bytes:
    """A small complete recording: surface speed and torque, 12 samples, run metadata."""
    from drill_twin.io.mcap_writer import McapRecorder
    from drill_twin.topics import SENSOR
    path = SCRATCH / 'good.mcap'
    rec = McapRecorder(path, chunk_period_s=0.05)
    for i in range(12):
        for topic in ('/surface/top_drive_speed', '/surface/torque'):
            rec.write(topic, 'std_msgs/msg/Float64', SENSOR, {'data': 12.0 + i},
                      i * 10_000_000)
    rec.add_metadata('drill_twin', {'scenario': '{}', 'namespace': '/'})
    rec.close()
    return path.read_bytes()


GOOD = _good_recording()
_WORDS = [b'\x00' * 8, b'\xff' * 8, struct.pack('<Q', 2 ** 63), struct.pack('<Q', 2 ** 40),
          struct.pack('<Q', len(GOOD)), struct.pack('<I', 0), b'\x89MCAP0\r\n']


@st.composite
def mutated(draw):
    """The good recording with bytes flipped, words (lengths, offsets) overwritten,
    ranges cut out or repeated, or the file cut short."""
    data = bytearray(GOOD)
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(data) - 1))
        kind = draw(st.sampled_from(['flip', 'word', 'cut', 'repeat', 'truncate']))
        if kind == 'flip':
            data[at] ^= draw(st.integers(1, 255))
        elif kind == 'word':
            word = draw(st.sampled_from(_WORDS))
            data[at:at + len(word)] = word
        elif kind == 'cut':
            del data[at:at + draw(st.integers(1, 64))]
        elif kind == 'repeat':
            data[at:at] = data[at:at + draw(st.integers(1, 64))]
        else:
            del data[at:]
        if not data:
            break
    return bytes(data)


@FUZZ
@given(mutated())
def test_mutated_recordings_open_and_read_or_give_a_recording_error(data):
    """Open a damaged recording (validated whole) and read and decode all its messages."""
    path = _file(data, 'input.mcap')

    def read():
        rec = open_recording(path)
        for _ in rec.decoded():
            pass
        check_decodable(rec)
    _user_error_only(read)
