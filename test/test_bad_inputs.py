"""A corpus of bad inputs: configurations, ``--set`` values, CLI arguments and corrupt
recordings.  Every one gives exactly one line on stderr, exit code 2 and no traceback
(the node parameters' corpus is in test_ros_processes.py; set-points sent to running
nodes are rejected with a log line in test_ros_nodes.py)."""
import struct
import subprocess
import sys

import pytest
from mcap.writer import Writer

from drill_twin.cli import main
from drill_twin.config.lookup import CONFIG_DIR
from drill_twin.config.scenario import load_scenario
from drill_twin.io.run_recorder import record_run

BENCH = (CONFIG_DIR / 'benchmark_fem.yaml').read_text()
RGD = (CONFIG_DIR / 'rgd_stick_slip.yaml').read_text()


def run(argv, capsys):
    """``drill-twin argv`` in process: (exit code, stderr lines)."""
    try:
        code = main(argv)
    except SystemExit as exc:   # argparse
        code = exc.code
    err = capsys.readouterr().err
    return code, [line for line in err.splitlines() if line.strip()]


def one_line_error(code, lines, *words):
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert 'Traceback' not in lines[0]
    for word in words:
        assert word in lines[0], (word, lines[0])


# --- configuration files --------------------------------------------------------------

def _edit(text, old, new):
    assert old in text, old
    return text.replace(old, new)


CONFIGS = {
    'malformed_yaml': ('units: si\nmodel: {type: fem\n', ['malformed YAML', 'line']),
    'empty_file': ('', ['empty configuration']),
    'only_comments': ('# nothing\n', ['empty configuration']),
    'a_list': ('- units: si\n', ['must be a mapping']),
    'a_scalar': ('42\n', ['must be a mapping']),
    'no_units': (_edit(BENCH, 'units: si\n', ''), ['missing required key units']),
    'units_typo': (_edit(BENCH, 'units: si', 'units: SI'), ['units', 'one of si, dimensionless']),
    'unknown_top_level': (BENCH + 'foo_unknown: 3\n', ['unknown key foo_unknown']),
    'typo_model_key': (_edit(BENCH, '  elements: 58', '  elemnts: 12'),
                       ['model.elemnts', 'did you mean model.elements']),
    'missing_pipe_length': (_edit(BENCH, '  pipe_length_m: 1000.0\n', ''),
                            ['missing required key drill_string.pipe_length_m']),
    'missing_operating_point': (_edit(BENCH, 'operating_point:', 'op:'), ['unknown key op']),
    'unknown_drill_string_key': (_edit(BENCH, '  bit_radius_m:', '  bit_radus_m:'),
                                 ['drill_string.bit_radus_m', 'did you mean '
                                  'drill_string.bit_radius_m']),
    'model_not_mapping': (_edit(BENCH, 'model:\n  type: fem', 'model: fem\nmodel_x:\n  type: f'),
                          ['model']),
    'unknown_model_type': (_edit(BENCH, 'type: fem', 'type: fm'), ['model.type',
                                                                     'did you mean fem']),
    'elements_not_integer': (_edit(BENCH, 'elements: 58', 'elements: 58.5'),
                             ['model.elements', 'an integer']),
    'elements_huge': (_edit(BENCH, 'elements: 58', 'elements: 1000000000'),
                      ['model.elements', '[2, 4096]']),
    'bha_not_below_elements': (_edit(BENCH, 'bha_elements: 10', 'bha_elements: 58'),
                               ['bha_elements', 'below']),
    'negative_length': (_edit(BENCH, 'pipe_length_m: 1000.0', 'pipe_length_m: -1000.0'),
                        ['pipe_length_m', ' m', '(0, 20000]']),
    'nan_density': (_edit(BENCH, 'density_kg_m3: 8000.0', 'density_kg_m3: .nan'),
                    ['density_kg_m3', 'kg/m^3']),
    'string_modulus': (_edit(BENCH, 'young_modulus_Pa: 200.0e+9', 'young_modulus_Pa: steel'),
                       ['young_modulus_Pa', 'a number']),
    'inner_radius_above_outer': (_edit(BENCH, 'pipe_inner_radius_m: 0.053975',
                                       'pipe_inner_radius_m: 0.07'), ['pipe_inner_radius_m']),
    'blades_zero': (_edit(BENCH, 'blades: 6', 'blades: 0'), ['blades', '[1, 64]']),
    'wob_below_friction': (_edit(BENCH, 'weight_on_bit_N: 60.5e+3', 'weight_on_bit_N: 1.0e+3'),
                           ['friction threshold']),
    'speed_zero': (_edit(BENCH, 'surface_speed_rad_s: 12.57', 'surface_speed_rad_s: 0'),
                   ['surface_speed_rad_s', 'rad/s']),
    'time_step_word': (_edit(BENCH, 'time_step: 5.0e-3', 'time_step: fast'),
                       ['simulation.time_step', "'auto'"]),
    'time_step_unstable': (_edit(BENCH, 'time_step: 5.0e-3', 'time_step: 0.5'),
                           ['time_step']),
    'time_step_tiny': (_edit(BENCH, 'time_step: 5.0e-3', 'time_step: 1.0e-12'),
                       ['simulation.time_step', '[1e-06, 1]']),
    'duration_for_other_units': (_edit(BENCH, 'duration_s: 250.0', 'duration: 250.0'),
                                 ['simulation.duration', 'duration_s']),
    'perturb_unknown': (_edit(BENCH, 'perturb: smooth', 'perturb: everywhere'),
                        ['simulation.perturb']),
    'perturbation_not_mapping': (_edit(BENCH, 'initial_perturbation: {u: 0.01, v: 0.01, phi: '
                                       '0.1, omega: 0.1}', 'initial_perturbation: 0.1'),
                                 ['simulation.initial_perturbation', 'mapping']),
    'perturbation_unknown_key': (_edit(BENCH, '{u: 0.01,', '{w: 0.01,'),
                                 ['initial_perturbation.w']),
    'groups_in_si_config': (BENCH + 'groups: {psi: 1}\n', ['groups', 'does not apply']),
    'drill_string_in_dimensionless': (RGD + 'drill_string: {pipe_length_m: 1}\n',
                                      ['drill_string', 'does not apply']),
    'groups_missing_omega': (_edit(RGD, '  omega_o: 5.0\n', ''), ['groups.omega_o']),
    'groups_lambda_twice': (_edit(RGD, '  n_b_lambda: 5.0', '  n_b_lambda: 5.0\n  lambda: 0.8'),
                            ['lambda']),
    'chain_without_kappa': (_edit(RGD, 'type: rgd', 'type: rgd_k'), ['kappa_d']),
    'key_not_a_name': (_edit(BENCH, 'units: si', 'units: si\n1: 2'), ['keys must be names']),
}


@pytest.mark.parametrize('case', sorted(CONFIGS))
def test_bad_configuration_file(case, tmp_path, capsys):
    text, words = CONFIGS[case]
    path = tmp_path / f'{case}.yaml'
    path.write_text(text)
    code, lines = run(['simulate', '--config', str(path), '--tau', '0.1'], capsys)
    one_line_error(code, lines, str(path) if case not in () else '', *words)


def test_binary_and_unreadable_configuration(tmp_path, capsys):
    binary = tmp_path / 'binary.yaml'
    binary.write_bytes(b'\x89PNG\r\n\x1a\n\x00\x00\xff\xfe')
    one_line_error(*run(['params', '--config', str(binary)], capsys), str(binary),
                   'not a text')
    folder = tmp_path / 'folder.yaml'
    folder.mkdir()
    one_line_error(*run(['params', '--config', str(folder)], capsys), 'not a file')
    one_line_error(*run(['params', '--config', 'no_such_name'], capsys),
                   'no such configuration', 'benchmark_fem')


# --- --set values ------------------------------------------------------------------------

SETS = [
    ('benchmark_fem', 'simulation.time_step=5e-3', None),        # YAML 1.1 string: a number
    ('benchmark_fem', 'model.elements=1e9', ['--set model.elements=1e9', '[2, 4096]']),
    ('benchmark_fem', 'model.elements=2.5', ['an integer']),
    ('benchmark_fem', 'model.elemnts=12', ['did you mean model.elements']),
    ('benchmark_fem', 'nonexistent.key=1', ['--set nonexistent.key=1', 'unknown key']),
    ('benchmark_fem', 'drill_string.foo=1', ['drill_string.foo']),
    ('benchmark_fem', 'model.elements', ['not KEY=VALUE']),
    ('benchmark_fem', '=3', ['not a dotted key']),
    ('benchmark_fem', 'model..elements=3', ['not a dotted key']),
    ('benchmark_fem', 'units.x=3', ['units is not a section']),
    ('benchmark_fem', 'model.elements=[1, 2', ['not valid YAML']),
    ('benchmark_fem', 'operating_point.weight_on_bit_N=.inf', ['weight_on_bit_N']),
    ('benchmark_fem', 'model={}', ['missing required key model.type']),
    ('rgd_stick_slip', 'groups.n_b=2.5', ['groups.n_b', 'an integer']),
    ('rgd_stick_slip', 'groups.psi=-1', ['groups.psi']),
]


@pytest.mark.parametrize('config, item, words', SETS, ids=[s[1] for s in SETS])
def test_bad_set_values(config, item, words, capsys):
    code, lines = run(['config', 'check', '--config', config, '--set', item], capsys)
    if words is None:
        assert code == 0, lines
        assert load_scenario(config, [item]).raw['simulation']['time_step'] == 5e-3
        return
    one_line_error(code, lines, *words)


# --- command-line arguments ---------------------------------------------------------------

ARGS = [
    (['simulate', '--config', 'benchmark_fem', '--duration', '-5'], ['--duration -5 s']),
    (['simulate', '--config', 'benchmark_fem', '--duration', 'nan'], ['--duration']),
    (['simulate', '--config', 'benchmark_fem', '--duration', 'abc'], ['invalid float']),
    (['simulate', '--config', 'rgd_stick_slip', '--duration', '5'], ['--tau']),
    (['simulate', '--config', 'rgd_stick_slip', '--tau', '0'], ['--tau']),
    (['simulate', '--config', 'rgd_stick_slip', '--tau', '10', '--stats-from', '20'],
     ['--stats-from']),
    (['simulate', '--config', 'benchmark_fem', '--duration', '1e7'], ['rows']),
    (['simulate', '--config', 'benchmark_fem', '--duration', '1', '--rate-hz', '0',
      '--out', 'x.mcap'], ['--rate-hz']),
    (['simulate'], ['--config']),
    (['simulat', '--config', 'benchmark_fem'], ['invalid choice']),
    (['stability', 'gallery', '--figure', '9.9'], ['unknown figure', '4.1.2']),
    (['reproduce', '--figure', '9.9', '--quick'], ['unknown figure']),
    (['stability', 'roots', '--config', 'benchmark_fem', '--count', '0'], ['--count']),
    (['stability', 'critical-speed', '--config', 'benchmark_fem', '--omega-min', '10',
      '--omega-max', '5'], ['--omega-min', 'rad/s']),
    (['stability', 'chart', '--config', 'axial_chain_2dof', '--x', 'groups.a:1:2',
      '--y', 'groups.b:1:2:3', '--out', 'c.png'], ['KEY:MIN:MAX:N']),
    (['stability', 'chart', '--config', 'axial_chain_2dof'], ['--x']),
    (['stability', 'roots'], ['--config']),
    (['simulate', '--config', 'rgd_stick_slip', '--set', 'model.type=semi_infinite',
      '--tau', '1', '--set', 'model.axial_impedance=1', '--set',
      'model.torsional_impedance=1'], ['stability model only']),
    (['mcap', 'recover', 'a.mcap'], ['FIXED']),
    (['config', 'check'], ['--config']),
]


@pytest.mark.parametrize('argv, words', ARGS, ids=[' '.join(a[0][:3]) + str(i)
                                                   for i, a in enumerate(ARGS)])
def test_bad_command_line(argv, words, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    one_line_error(*run(argv, capsys), *words)


# --- corrupt recordings ------------------------------------------------------------------

@pytest.fixture(scope='module')
def good(tmp_path_factory):
    path = tmp_path_factory.mktemp('rec') / 'good.mcap'
    record_run(load_scenario('benchmark_fem'), path, 0.5, 100.0, config='benchmark_fem')
    return path.read_bytes()


def _records(data):
    """``(offset, opcode, length)`` of the top-level records after the magic."""
    out, pos = [], 8
    while pos + 9 <= len(data) - 8:
        op, length = struct.unpack_from('<BQ', data, pos)
        out.append((pos, op, length))
        pos += 9 + length
    return out


def _flip(data, at):
    bad = bytearray(data)
    bad[at] ^= 0xFF
    return bytes(bad)


def _first(data, opcode, nth=0):
    found = [(o, n) for o, op, n in _records(data) if op == opcode]
    return found[nth]


def _corrupt(case, data, tmp):
    """The bytes of one corrupt variant of a good recording."""
    if case == 'text':
        return b'time,speed\n0,1\n'
    if case == 'empty':
        return b''
    if case == 'magic_only':
        return data[:8]
    if case == 'truncated_half':
        return data[:len(data) // 2]
    if case == 'no_footer':
        return data[:-8]
    if case == 'chunk_byte':        # inside the compressed data of the first chunk
        off, n = _first(data, 0x06)
        return _flip(data, off + 9 + n // 2)
    if case == 'message_index_time':  # a log time of a message index entry
        off, _ = _first(data, 0x07)
        return _flip(data, off + 9 + 2 + 4 + 3)
    if case == 'message_index_offset':
        off, _ = _first(data, 0x07)
        return _flip(data, off + 9 + 2 + 4 + 8)
    if case == 'summary_byte':      # a byte inside the statistics of the summary
        off, _ = _first(data, 0x0B)
        return _flip(data, off + 12)
    if case == 'footer_offset':
        return _flip(data, len(data) - 8 - 20 + 3)
    if case == 'schema_text_in_summary':
        at = data.rfind(b'float64 data')
        return _flip(data, at + 3)
    if case in ('json_profile', 'ros2_json_channel', 'undecodable_cdr'):
        path = tmp / 'foreign.mcap'
        with open(path, 'wb') as f:
            w = Writer(f)
            w.start(profile='' if case == 'json_profile' else 'ros2', library='test')
            if case == 'undecodable_cdr':   # a Float64 channel whose messages are 3 bytes
                sid = w.register_schema('std_msgs/msg/Float64', 'ros2msg', b'float64 data')
                cid = w.register_channel('/x', 'cdr', sid)
                w.add_message(cid, log_time=0, data=b'\x00\x01\x00', publish_time=0)
            else:
                sid = w.register_schema('x', 'jsonschema', b'{}')
                cid = w.register_channel('/x', 'json', sid)
                w.add_message(cid, log_time=0, data=b'{}', publish_time=0)
            w.finish()
        return path.read_bytes()
    raise AssertionError(case)


MCAP_CASES = {
    'text': 'not an MCAP file', 'empty': 'not an MCAP file', 'magic_only': 'incomplete',
    'truncated_half': 'incomplete', 'no_footer': 'incomplete', 'chunk_byte': 'corrupt',
    'message_index_time': 'message index', 'message_index_offset': 'message index',
    'summary_byte': 'summary', 'footer_offset': 'MCAP', 'schema_text_in_summary': 'summary',
    'json_profile': 'not a ROS 2 recording', 'ros2_json_channel': 'not a ROS 2 CDR channel',
    'undecodable_cdr': 'do not decode',
}


@pytest.mark.parametrize('case', sorted(MCAP_CASES))
def test_corrupt_recordings(case, good, tmp_path, capsys):
    path = tmp_path / 'bad.mcap'
    path.write_bytes(_corrupt(case, good, tmp_path))
    commands = [['mcap', 'info', str(path)], ['mcap', 'export', str(path), '--csv',
                                               str(tmp_path / 'csv')],
                ['replay', str(path), '--resimulate']]
    if case == 'undecodable_cdr':
        commands = [['replay', str(path), '--delay', '0']]
    for argv in commands:
        code, lines = run(argv, capsys)
        one_line_error(code, lines, MCAP_CASES[case])
    if case.startswith('message_index') or case == 'chunk_byte':
        # recover rewrites what the chunks hold, with fresh indexes, and says the input
        # was not complete
        code = main(['mcap', 'recover', str(path), str(tmp_path / 'fixed.mcap'), '--json'])
        out = capsys.readouterr().out
        assert code == 0 and '"complete": false' in out
        assert main(['mcap', 'info', str(tmp_path / 'fixed.mcap')]) == 0


def test_recover_refuses_a_json_channel(good, tmp_path, capsys):
    path = tmp_path / 'json.mcap'
    path.write_bytes(_corrupt('ros2_json_channel', good, tmp_path))
    one_line_error(*run(['mcap', 'recover', str(path), str(tmp_path / 'out.mcap')], capsys),
                   'not a ROS 2 CDR channel')


def test_an_internal_error_keeps_its_traceback(tmp_path):
    """Not bad input: a bug.  Its traceback is shown and the exit code is 1, not 2."""
    code = ('import drill_twin.cli as c, drill_twin.config.cli as cc\n'
            'def boom(args):\n    raise ValueError("a bug")\n'
            'cc.cmd_params = boom\n'
            'import sys; sys.exit(c.main(["params", "--config", "rgd_stick_slip"]))\n')
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 1 and 'Traceback' in proc.stderr and 'a bug' in proc.stderr


# --- the bounds of the YAML reader (drill_twin.config.yaml_bounds.parse_yaml) --------------

def test_yaml_bounds_are_where_the_constants_say():
    from drill_twin.config.yaml_bounds import (
        MAX_INT_DIGITS,
        MAX_YAML_DEPTH,
        MAX_YAML_NODES,
        parse_yaml,
    )
    from drill_twin.errors import ConfigError
    deep = '[' * MAX_YAML_DEPTH + ']' * MAX_YAML_DEPTH
    assert parse_yaml(deep, 'x') is not None
    with pytest.raises(ConfigError, match=f'x: line 1, column {MAX_YAML_DEPTH + 1}: YAML '
                                          f'nested deeper than {MAX_YAML_DEPTH} levels'):
        parse_yaml(f'[{deep}]', 'x')
    most = '[' + ', '.join(['0'] * (MAX_YAML_NODES - 1)) + ']'     # and the list itself
    assert len(parse_yaml(most, 'x')) == MAX_YAML_NODES - 1
    with pytest.raises(ConfigError, match=f'more than {MAX_YAML_NODES} YAML nodes'):
        parse_yaml(most[:-1] + ', 0]', 'x')
    assert parse_yaml('9' * MAX_INT_DIGITS, 'x') == int('9' * MAX_INT_DIGITS)
    with pytest.raises(ConfigError, match=f'{MAX_INT_DIGITS + 1} digits'):
        parse_yaml('1' + '0' * MAX_INT_DIGITS, 'x')


def test_aliases_within_the_budget_still_work(tmp_path):
    """A scenario that repeats a step through an alias (what anchors are for) loads."""
    from drill_twin.operations.timeline import load_timeline
    path = tmp_path / 'repeat.yaml'
    path.write_text('configuration: benchmark_fem\nsteps:\n'
                    '  - &turn {rotate: {rpm: 60, ramp_s: 5}}\n  - wait: {for_s: 1}\n'
                    '  - *turn\n')
    steps = load_timeline(path).steps
    assert steps[0].params == steps[2].params and len(steps) == 3


def _zstd_frame_claiming(size: int) -> bytes:
    """A zstd frame of 1000 zero bytes whose header says it holds ``size`` bytes (an
    8-byte frame content size field, single segment)."""
    import zstandard
    frame = zstandard.ZstdCompressor(write_content_size=True).compress(bytes(1000))
    assert frame[4] == 0x60                      # 2-byte content size, single segment
    return frame[:4] + bytes([0xE0]) + struct.pack('<Q', size) + frame[7:]


def test_recover_stops_at_a_chunk_that_claims_a_terabyte(tmp_path, capsys):
    """The zstd frame of a chunk says 2^40 bytes: zstandard would allocate them
    (MemoryError); recover stops reading there as at any damaged record."""
    from mcap.data_stream import RecordBuilder
    from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Schema

    from drill_twin.io.mcap_reader import MAX_CHUNK_BYTES
    builder = RecordBuilder()
    for record in (Header(profile='ros2', library='test'),
                   Schema(id=1, name='std_msgs/msg/Float64', encoding='ros2msg',
                          data=b'float64 data'),
                   Channel(id=1, topic='/x', message_encoding='cdr', schema_id=1,
                           metadata={}),
                   Chunk(compression='zstd', data=_zstd_frame_claiming(2 ** 40),
                         message_start_time=0, message_end_time=0, uncompressed_crc=0,
                         uncompressed_size=1000),
                   DataEnd(data_section_crc=0), Footer(0, 0, 0)):
        record.write(builder)
    path = tmp_path / 'claims.mcap'
    path.write_bytes(b'\x89MCAP0\r\n' + builder.end() + b'\x89MCAP0\r\n')
    assert main(['mcap', 'recover', str(path), str(tmp_path / 'fixed.mcap'), '--json']) == 0
    out = capsys.readouterr().out
    assert '"complete": false' in out and f'more than the {MAX_CHUNK_BYTES}' in out
