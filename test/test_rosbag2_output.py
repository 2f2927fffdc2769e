"""What rosbag2 itself writes, checked on drill_twin's recordings (references: the rosbag2
Jazzy sources — rosbag2_storage_mcap/mcap_storage.cpp, rosbag2_storage/yaml.hpp,
rosbag2_cpp/.../local_message_definition_source.cpp — the installed .msg and type
description .json files), and the writer's crash safety at the level of bytes on disk."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
import yaml
from mcap.reader import make_reader

from drill_twin.config.scenario import load_scenario
from drill_twin.io.mcap_reader import open_recording, recover
from drill_twin.io.msg_definitions import find_msg_file, schema_text
from drill_twin.io.run_recorder import record_run


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('bag') / 'run.mcap'
    record_run(load_scenario('benchmark_fem'), path, 3.0, 100.0, config='benchmark_fem')
    return path


def _installed_hash(type_name):
    """The RIHS01 hash of pkg/msg/Type read straight from its installed .json."""
    pkg, _, name = type_name.split('/')
    data = json.loads(find_msg_file(f'{pkg}/{name}').with_suffix('.json').read_text())
    return next(h['hash_string'] for h in data['type_hashes'] if h['type_name'] == type_name)


def test_schema_dependencies_in_rosbag2_order_with_files_verbatim():
    """rosbag2: root file verbatim, then per definition its dependencies in alphabetical
    order (std::set), depth first, each once, joined by '\\n' + 80 '=' + 'MSG: pkg/Type'."""
    text = schema_text('geometry_msgs/msg/TwistWithCovarianceStamped')
    order = ['geometry_msgs/TwistWithCovariance', 'geometry_msgs/Twist',
             'geometry_msgs/Vector3', 'std_msgs/Header', 'builtin_interfaces/Time']
    expected = find_msg_file('geometry_msgs/TwistWithCovarianceStamped').read_text()
    for name in order:
        expected += '\n' + '=' * 80 + f'\nMSG: {name}\n' + find_msg_file(name).read_text()
    assert text == expected


def test_metadata_record_parses_as_rosbag2_bag_metadata(bag):
    with open(bag, 'rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        records = {m.name: m.metadata for m in reader.iter_metadata()}
    meta = yaml.safe_load(records['rosbag2']['serialized_metadata'])
    stats = summary.statistics
    assert meta['version'] == 9 and meta['storage_identifier'] == 'mcap'
    assert meta['message_count'] == stats.message_count > 0
    assert meta['starting_time']['nanoseconds_since_epoch'] == stats.message_start_time
    assert meta['duration']['nanoseconds'] == stats.message_end_time - stats.message_start_time
    assert meta['relative_file_paths'] == [bag.name] and meta['files'][0]['path'] == bag.name
    assert meta['ros_distro'] == 'jazzy' and meta['compression_mode'] == ''
    topics = {t['topic_metadata']['name']: t for t in meta['topics_with_message_count']}
    assert len(topics) == len(summary.channels)
    for cid, channel in summary.channels.items():
        entry = topics[channel.topic]
        schema = summary.schemas[channel.schema_id]
        tm = entry['topic_metadata']
        assert entry['message_count'] == stats.channel_message_counts.get(cid, 0)
        assert tm['type'] == schema.name and tm['serialization_format'] == 'cdr'
        assert tm['offered_qos_profiles'] == yaml.safe_load(
            channel.metadata['offered_qos_profiles'])
        assert tm['type_description_hash'] == channel.metadata['topic_type_hash'] == \
            _installed_hash(schema.name)


def test_a_path_without_suffix_is_a_rosbag2_bag_directory(tmp_path):
    """``DIR/DIR_0.mcap`` + ``DIR/metadata.yaml`` (rosbag2_storage's MetadataIo layout: the
    BagMetadata under ``rosbag2_bagfile_information``, the same mapping as the record in the
    file); readers take the directory; an existing directory is refused, not overwritten."""
    directory = tmp_path / 'run_bag'
    record_run(load_scenario('benchmark_fem'), directory, 1.0, 100.0, config='benchmark_fem')
    assert sorted(p.name for p in directory.iterdir()) == ['metadata.yaml', 'run_bag_0.mcap']
    info = yaml.safe_load((directory / 'metadata.yaml').read_text())
    with open(directory / 'run_bag_0.mcap', 'rb') as f:
        records = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert info == {'rosbag2_bagfile_information': yaml.safe_load(
        records['rosbag2']['serialized_metadata'])}
    meta = info['rosbag2_bagfile_information']
    assert meta['relative_file_paths'] == ['run_bag_0.mcap']
    recording = open_recording(directory)
    assert sum(recording.message_counts.values()) == meta['message_count'] > 0
    with pytest.raises(OSError, match='exists'):
        record_run(load_scenario('benchmark_fem'), directory, 1.0, 100.0)
    assert yaml.safe_load((directory / 'metadata.yaml').read_text()) == info


def test_recovered_file_gets_a_metadata_record_of_what_was_recovered(bag, tmp_path):
    data = bag.read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:len(data) * 2 // 3])
    fixed = tmp_path / 'fixed.mcap'
    counts = recover(cut, fixed)
    with open(fixed, 'rb') as f:
        reader = make_reader(f)
        records = [m for m in reader.iter_metadata() if m.name == 'rosbag2']
    assert len(records) == 1
    meta = yaml.safe_load(records[0].metadata['serialized_metadata'])
    assert meta['message_count'] == counts['messages'] > 0
    assert meta['relative_file_paths'] == ['fixed.mcap']


# --- crash safety, byte level -----------------------------------------------------------
WRITER = textwrap.dedent('''
    import io, os, sys, time
    from drill_twin.io import mcap_writer
    from drill_twin.topics import BY_NAME
    path, period, brk = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    rec = mcap_writer.McapRecorder(path, chunk_period_s=period, compression='none')
    if brk == 'late':        # a chunk closed one period late
        rec.chunk_period_s = 2 * period
    elif brk == 'unflushed': # chunks written to a process buffer, never handed to the OS
        class Held(io.BufferedWriter):
            def flush(self):
                pass
        rec._file = Held(io.FileIO(os.dup(rec._file.fileno()), 'wb'), buffer_size=1 << 24)
    topic = BY_NAME['surface/torque']
    rec.write(topic.name, topic.type, topic.qos, {'data': 0.0}, time.time_ns())
    print('ready', flush=True)
    while True:
        rec.write(topic.name, topic.type, topic.qos, {'data': 1.0}, time.time_ns())
        time.sleep(0.005)
''')


def crash_safety(tmp_path, brk, period=1.0, run_s=4.5):
    """Run a writer (wall-clock log times) with a ``period`` chunk period, watch the file
    on disk, SIGKILL it, recover; returns (largest interval without growth, log time lost
    at the kill), both in seconds."""
    path = tmp_path / f'crash_{brk}.mcap'
    proc = subprocess.Popen([sys.executable, '-c', WRITER, str(path), str(period), brk],
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == 'ready'
        start = last_growth = time.monotonic()
        size, gap = path.stat().st_size, 0.0
        while time.monotonic() - start < run_s:     # polling the disk is the measurement
            now_size = path.stat().st_size
            now = time.monotonic()
            if now_size > size:
                gap, size, last_growth = max(gap, now - last_growth), now_size, now
            time.sleep(0.01)
        gap = max(gap, time.monotonic() - last_growth)
        killed_ns = time.time_ns()
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    fixed = tmp_path / f'fixed_{brk}.mcap'
    recover(path, fixed)
    with open(fixed, 'rb') as f:
        last = max((m.log_time for _, _, m in make_reader(f).iter_messages()), default=0)
    return gap, (killed_ns - last) * 1e-9


@pytest.mark.timeout(120)
def test_file_grows_every_chunk_period_and_a_kill_loses_at_most_one(tmp_path):
    """The writer as shipped passes; each of the two deliberate breaks fails (a chunk closed
    one period late: growth every two periods, two lost; chunks never flushed to the OS:
    nothing on disk).  Slack: half a period for scheduling on a loaded machine."""
    period = 1.0

    def passes(brk):
        gap, lost = crash_safety(tmp_path, brk, period)
        return gap <= 1.5 * period and lost <= 1.5 * period
    assert passes('none')
    assert not passes('late')
    assert not passes('unflushed')
