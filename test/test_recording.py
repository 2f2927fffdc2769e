"""MCAP recording (issue 6) without ROS processes: rosbag2 layout, independent readers,
exact resimulation, recovery, clear errors on bad files."""
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from mcap_ros2.decoder import DecoderFactory

from drill_twin.config.scenario import load_scenario
from drill_twin.io.mcap_reader import RecordingError, open_recording, recover
from drill_twin.io.msg_definitions import find_msg_file, schema_text
from drill_twin.io.resimulation import resimulate
from drill_twin.io.run_recorder import TwinRecorder, record_run
from drill_twin.runtime.digital_twin import DigitalTwin, aligned_step
from drill_twin.topics import BY_NAME, MEASUREMENTS

RATE_HZ = 100.0


@pytest.fixture(scope='module')
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp('rec') / 'run.mcap'
    record_run(load_scenario('benchmark_fem'), path, 5.0, RATE_HZ, config='benchmark_fem')
    return path


def test_schema_text_is_the_rosbag2_concatenation():
    """Reference: the rosbag2 ros2msg layout (root, then each nested type once after 80
    '=' and 'MSG: pkg/Type'), and the installed .msg files themselves."""
    text = schema_text('geometry_msgs/msg/TwistStamped')
    blocks = text.split('=' * 80 + '\n')
    assert blocks[0].strip() == find_msg_file('geometry_msgs/msg/TwistStamped').read_text().strip()
    names = [b.splitlines()[0] for b in blocks[1:]]
    assert sorted(names) == sorted(['MSG: std_msgs/Header', 'MSG: builtin_interfaces/Time',
                                    'MSG: geometry_msgs/Twist', 'MSG: geometry_msgs/Vector3'])
    for block in blocks[1:]:
        name = block.splitlines()[0][len('MSG: '):]
        body = block.split('\n', 1)[1]
        assert body.strip() == find_msg_file(name).read_text().strip()


def test_recording_opens_in_the_mcap_and_rosbags_readers(run_file):
    """Independent readers: mcap's decoded reader and rosbags' AnyReader; values against a
    twin run here at the same ticks (the test's own loop)."""
    from rosbags.highlevel import AnyReader
    ticks = int(5.0 * RATE_HZ)
    sc = load_scenario('benchmark_fem')   # the step divides the tick, as in the node
    twin = DigitalTwin(sc, time_step_s=aligned_step(sc.time_step * sc.time_unit_s,
                                                    1.0 / RATE_HZ))
    expected = []
    for k in range(1, ticks + 1):
        twin.advance_to(k / RATE_HZ)
        expected.append(twin.measurements())

    with open(run_file, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
        assert summary.statistics.chunk_count > 1 and summary.chunk_indexes
        assert {s.encoding for s in summary.schemas.values()} == {'ros2msg'}
        assert {c.message_encoding for c in summary.channels.values()} == {'cdr'}
        by_topic = {c.topic: c for c in summary.channels.values()}
        assert by_topic['/bit/velocity'].schema_id in summary.schemas
        assert summary.schemas[by_topic['/bit/velocity'].schema_id].name == \
            'geometry_msgs/msg/TwistStamped'
        bit = [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(['/bit/velocity'])]
    assert len(bit) == ticks
    log_s = np.array([t for t, _ in bit]) * 1e-9
    assert np.allclose(log_s, [m['time_s'] for m in expected], atol=1e-9)  # simulated time
    assert [d.twist.angular.x for _, d in bit] == [m['bit_angular_speed_rad_s']
                                                    for m in expected]

    with AnyReader([Path(run_file)]) as ar:
        conns = {c.topic: c for c in ar.connections}
        assert conns['/bit/wrench'].msgtype == 'geometry_msgs/msg/WrenchStamped'
        assert conns['/bit/stuck'].msgtype == 'std_msgs/msg/Bool'
        for t in MEASUREMENTS:
            assert conns['/' + t.name].msgcount == ticks
            qos = conns['/' + t.name].ext.offered_qos_profiles[0]
            assert qos.reliability.name.lower() == t.qos.reliability
            assert qos.durability.name.lower() == t.qos.durability
            assert qos.depth == t.qos.depth
        sp = BY_NAME['surface_speed_setpoint'].qos
        assert conns['/surface_speed_setpoint'].ext.offered_qos_profiles[0].durability \
            .name.lower() == sp.durability
        wob, tob = [], []
        for conn, _, raw in ar.messages(connections=[conns['/bit/wrench']]):
            msg = ar.deserialize(raw, conn.msgtype)
            wob.append(msg.wrench.force.x)
            tob.append(msg.wrench.torque.x)
    assert wob == [m['weight_on_bit_N'] for m in expected]
    assert tob == [m['torque_on_bit_Nm'] for m in expected]


def test_run_metadata_describes_the_run(run_file):
    rec = open_recording(run_file)
    run = rec.run
    assert run['time_base'] == 'simulated' and run['model'] == 'fem_58'
    assert run['scenario'] == load_scenario('benchmark_fem').raw
    assert run['config'] == 'benchmark_fem' and run['package_version']


def test_resimulation_is_exact_and_the_setpoints_matter(tmp_path):
    """A run with set-point changes (one rejected) recorded by the twin's recorder, then
    resimulated: every field identical; without the set-points it is not."""
    twin = DigitalTwin(load_scenario('benchmark_fem'))
    rec = TwinRecorder(tmp_path / 'steps.mcap', twin, 'benchmark_fem')
    for k in range(1, 601):
        if k in (100, 300, 420):
            value = {100: 16.0, 300: float('nan'), 420: 9.0}[k]
            rec.setpoint('surface_speed_setpoint', value)
            try:
                twin.set_surface_speed(value)
            except ValueError:
                pass
        twin.advance_to(k / RATE_HZ)
        rec.measurements(twin.measurements())
    rec.close()
    recording = open_recording(tmp_path / 'steps.mcap')
    report = resimulate(recording)
    assert report['ticks'] == 600
    assert report['setpoints_applied'] == 2 and report['setpoints_rejected'] == 1
    assert all(v['max_abs_difference'] == 0.0 for v in report['topics'].values())
    assert len(report['topics']) == len(MEASUREMENTS)
    blind = resimulate(recording, apply_setpoints=False)
    assert blind['topics']['/surface/top_drive_speed']['max_abs_difference'] > 3.0  # |16 - 12.57|


def test_killed_file_is_recovered_up_to_the_last_chunk(tmp_path, run_file):
    """Truncation anywhere: recover keeps a prefix of the messages, complete chunks only."""
    data = run_file.read_bytes()
    full = [(t, m.log_time) for t, m in _messages(run_file)]
    for fraction in (0.3, 0.75, 0.999):
        broken = tmp_path / f'broken_{fraction}.mcap'
        broken.write_bytes(data[:int(len(data) * fraction)])
        with pytest.raises(RecordingError, match='recover'):
            open_recording(broken)
        fixed = tmp_path / f'fixed_{fraction}.mcap'
        counts = recover(broken, fixed)
        got = [(t, m.log_time) for t, m in _messages(fixed)]
        assert counts['messages'] == len(got) > 0
        assert got == full[:len(got)]  # a prefix, in order
    # the summary (indexes, statistics) is the only thing after the data: nearly all kept
    assert len(got) == len(full)


def _messages(path):
    with open(path, 'rb') as f:
        for _, channel, msg in make_reader(f).iter_messages(log_time_order=False):
            yield channel.topic, msg


def _foreign(path, profile, encoding):
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start(profile=profile, library='test')
        sid = w.register_schema('x', 'jsonschema', b'{}')
        cid = w.register_channel('/x', encoding, sid)
        w.add_message(cid, log_time=0, data=b'{}', publish_time=0)
        w.finish()


@pytest.mark.parametrize('case', ['text', 'empty', 'truncated', 'flipped', 'json_profile',
                                  'ros2_json_channel', 'missing'])
def test_bad_files_give_a_clear_error_not_a_traceback(tmp_path, run_file, case):
    path = tmp_path / 'bad.mcap'
    data = run_file.read_bytes()
    expect = {'text': 'not an MCAP file', 'empty': 'not an MCAP file',
              'truncated': 'incomplete', 'flipped': 'corrupt', 'json_profile':
              'not a ROS 2 recording', 'ros2_json_channel': 'not a ROS 2 CDR channel',
              'missing': 'no such file'}[case]
    if case == 'text':
        path.write_text('time,speed\n0,1\n')
    elif case == 'empty':
        path.write_bytes(b'')
    elif case == 'truncated':
        path.write_bytes(data[:len(data) // 2])
    elif case == 'flipped':  # one byte in a compressed chunk
        bad = bytearray(data)
        bad[len(bad) // 2] ^= 0xFF
        path.write_bytes(bytes(bad))
    elif case == 'json_profile':
        _foreign(path, '', 'json')
    elif case == 'ros2_json_channel':
        _foreign(path, 'ros2', 'json')
    for args in (['mcap', 'info', str(path)], ['mcap', 'export', str(path), '--csv',
                                                str(tmp_path / 'csv')],
                 ['replay', str(path), '--resimulate']):
        proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', *args],
                              capture_output=True, text=True, timeout=60)
        if case == 'flipped' and args[1] == 'info':
            continue  # the summary is intact: info reads only the summary
        assert proc.returncode == 2, (args, proc.stdout, proc.stderr)
        assert expect in proc.stderr and 'Traceback' not in proc.stderr, proc.stderr


def test_export_csv_and_plot(tmp_path, run_file):
    out = subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'mcap', 'export',
                          str(run_file), '--csv', str(tmp_path / 'csv'), '--json'],
                         capture_output=True, text=True, timeout=60, check=True)
    paths = json.loads(out.stdout)
    with open(paths['/bit/wrench']) as f:
        header = next(csv.reader(f))
    assert header[0] == 'log_time [s]'
    assert 'wrench.force.x [N]' in header and 'wrench.torque.x [N.m]' in header
    rows = np.genfromtxt(paths['/bit/wrench'], delimiter=',', skip_header=1)
    decoded = list(open_recording(run_file).decoded(['/bit/wrench']))
    assert len(rows) == len(decoded)
    col = header.index('wrench.force.x [N]')
    assert np.allclose(rows[:, col], [m.wrench.force.x for _, _, m in decoded], rtol=1e-15)
    assert np.allclose(rows[:, 0], [t * 1e-9 for _, t, _ in decoded], atol=1e-9)
    png = tmp_path / 'run.png'
    subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'mcap', 'plot', str(run_file),
                    '--out', str(png)], check=True, capture_output=True, timeout=60)
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_las_export_reads_back_with_the_recorded_values(tmp_path, run_file):
    """LAS 2.0 from `mcap export --las`, read back with lasio (an independent reader): the
    curves, their SI units, and every value equal to the decoded messages."""
    import lasio
    path = tmp_path / 'run.las'
    subprocess.run([sys.executable, '-m', 'drill_twin.cli', 'mcap', 'export', str(run_file),
                    '--las', str(path)], check=True, capture_output=True, timeout=60)
    las = lasio.read(path)
    assert las.version['VERS'].value == 2.0
    units = {c.mnemonic: c.unit for c in las.curves}
    assert units['TIME'] == 's' and units['WOB'] == 'N' and units['TOB'] == 'N.m'
    assert units['BITRS'] == 'rad/s' and units['TDSPD'] == 'rad/s'
    rec = open_recording(run_file)
    wrench = list(rec.decoded(['/bit/wrench']))
    speed = list(rec.decoded(['/surface/top_drive_speed']))
    assert len(las['TIME']) == len(wrench) == len(speed)
    assert np.allclose(las['TIME'], [t * 1e-9 for _, t, _ in wrench], atol=1e-9)
    assert np.allclose(las['WOB'], [m.wrench.force.x for _, _, m in wrench], rtol=1e-9)
    assert np.allclose(las['TOB'], [m.wrench.torque.x for _, _, m in wrench], rtol=1e-9)
    assert np.allclose(las['TDSPD'], [m.data for _, _, m in speed], rtol=1e-9)
