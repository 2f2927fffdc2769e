"""The ``rosbag2`` metadata record of an MCAP file, as rosbag2 Jazzy writes it.

``rosbag2_storage_mcap`` ends a recording with an MCAP metadata record named ``rosbag2``
whose one key ``serialized_metadata`` is the bag metadata YAML (``rosbag2_storage/
yaml.hpp``, ``BagMetadata`` version 9): version, storage identifier, duration
(``nanoseconds``), starting time (``nanoseconds_since_epoch``), message count, every topic
with its type, serialization format, offered QoS profiles (a YAML list in version 9),
type description hash and message count, compression (none: MCAP chunks carry their own),
the relative file paths, the files, custom data and the ROS distribution.  ``ros2 bag
info`` reads the same numbers from the MCAP summary; the record is what rosbag2 itself
leaves in a file it wrote.
"""
from __future__ import annotations

from pathlib import Path

import yaml

__all__ = ['bag_metadata', 'serialized_metadata', 'topic_entry', 'ROSBAG2_VERSION',
           'RECORD_NAME', 'METADATA_FILE', 'bag_directory', 'write_bag_metadata_file',
           'bag_file']

ROSBAG2_VERSION = 9
RECORD_NAME = 'rosbag2'
#: a bag directory's metadata file (``rosbag2_storage::MetadataIo``)
METADATA_FILE = 'metadata.yaml'


def bag_metadata(file_name: str, topics: list[dict], start_ns: int, end_ns: int,
                 ros_distro: str = 'jazzy') -> dict:
    """The BagMetadata mapping.  ``topics``: one dict per channel with ``name``, ``type``
    (``pkg/msg/Type``), ``offered_qos_profiles`` (the channel's YAML text),
    ``type_description_hash`` and ``message_count``."""
    count = sum(int(t['message_count']) for t in topics)
    duration = max(int(end_ns) - int(start_ns), 0) if count else 0
    start = int(start_ns) if count else 0
    return {
        'version': ROSBAG2_VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': duration},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': count,
        'topics_with_message_count': [{
            'topic_metadata': {
                'name': t['name'], 'type': t['type'], 'serialization_format': 'cdr',
                'offered_qos_profiles': yaml.safe_load(t['offered_qos_profiles'] or '[]'),
                'type_description_hash': t.get('type_description_hash', '')},
            'message_count': int(t['message_count'])} for t in topics],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [file_name],
        'files': [{'path': file_name, 'starting_time': {'nanoseconds_since_epoch': start},
                   'duration': {'nanoseconds': duration}, 'message_count': count}],
        'custom_data': None,
        'ros_distro': ros_distro,
    }


def topic_entry(channel, type_name: str, message_count: int) -> dict:
    """The :func:`bag_metadata` entry of an MCAP channel record (its QoS and type-hash
    metadata, '' where the file has none)."""
    return {'name': channel.topic, 'type': type_name,
            'offered_qos_profiles': channel.metadata.get('offered_qos_profiles', '[]'),
            'type_description_hash': channel.metadata.get('topic_type_hash', ''),
            'message_count': int(message_count)}


def serialized_metadata(metadata: dict) -> str:
    """The YAML text of the record (block style, keys in rosbag2's order)."""
    return yaml.safe_dump(metadata, sort_keys=False, default_flow_style=False)


def bag_directory(path) -> Path | None:
    """The bag directory a recording path names: a path without a suffix (or an existing
    directory); None for a plain ``.mcap`` file."""
    path = Path(path)
    return path if path.is_dir() or not path.suffix else None


def write_bag_metadata_file(directory, metadata: dict) -> Path:
    """``DIR/metadata.yaml`` as ``MetadataIo::write_metadata`` writes it: the BagMetadata
    mapping under ``rosbag2_bagfile_information``."""
    out = Path(directory) / METADATA_FILE
    out.write_text(serialized_metadata({'rosbag2_bagfile_information': metadata}))
    return out


def bag_file(directory) -> Path:
    """The MCAP file of a bag directory (the first of its ``relative_file_paths``; without
    metadata.yaml -- a killed recorder -- its only ``.mcap`` file)."""
    directory = Path(directory)
    meta = directory / METADATA_FILE
    if meta.is_file():
        info = yaml.safe_load(meta.read_text()) or {}
        paths = (info.get('rosbag2_bagfile_information') or {}).get('relative_file_paths')
        if paths:
            return directory / paths[0]
    files = sorted(directory.glob('*.mcap'))
    return files[0] if len(files) == 1 else directory / METADATA_FILE
