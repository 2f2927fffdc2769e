"""Read drill_twin (rosbag2-profile) MCAP recordings, and recover killed ones.

Every failure of a corrupt, truncated or foreign file is raised as
:class:`RecordingError` with a sentence that says what is wrong and what to
do (e.g. "run ``drill-twin mcap recover``"), never a library traceback.
"""
from __future__ import annotations

import json
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader
from mcap.writer import CompressionType, Writer
from mcap_ros2._dynamic import generate_dynamic

from .mcap_writer import PROFILE

__all__ = ['RecordingError', 'Recording', 'open_recording', 'recover', 'RUN_METADATA']

_MAGIC = b'\x89MCAP'
#: name of the MCAP metadata record with the run description
RUN_METADATA = 'drill_twin'

_READ_ERRORS = (McapError, CRCValidationError, struct.error, EOFError, ValueError,
                KeyError, IndexError, UnicodeDecodeError, zlib.error, OSError, RuntimeError)
try:  # the chunk decompressors raise their own errors
    import zstandard
    _READ_ERRORS += (zstandard.ZstdError,)
except ImportError:  # pragma: no cover
    pass


class RecordingError(Exception):
    """A recording that cannot be read as a drill_twin/rosbag2 MCAP file (message says why)."""


@dataclass
class ChannelInfo:
    topic: str
    type: str          # pkg/msg/Type
    schema_text: str
    offered_qos_profiles: str


@dataclass
class Recording:
    """An opened recording: channels, run metadata, and message iterators."""

    path: Path
    library: str
    channels: dict[int, ChannelInfo]
    metadata: dict[str, dict] = field(default_factory=dict)
    message_counts: dict[str, int] = field(default_factory=dict)
    _decoders: dict = field(default_factory=dict, repr=False)

    @property
    def run(self) -> dict:
        """The drill_twin run description (empty for foreign ROS 2 recordings)."""
        return self.metadata.get(RUN_METADATA, {})

    @property
    def topics(self) -> dict[str, str]:
        return {c.topic: c.type for c in self.channels.values()}

    def messages(self, topics=None):
        """``(topic, log_time_ns, cdr_bytes)`` in the order they were written."""
        wanted = None if topics is None else set(topics)
        try:
            with open(self.path, 'rb') as f:
                reader = SeekingReader(f, validate_crcs=True)
                for _, channel, msg in reader.iter_messages(log_time_order=False):
                    if wanted is None or channel.topic in wanted:
                        yield channel.topic, msg.log_time, msg.data
        except _READ_ERRORS as exc:
            raise RecordingError(f'{self.path}: corrupt MCAP data ({_why(exc)}); try '
                                 f'`drill-twin mcap recover {self.path} FIXED.mcap`') from None

    def decoder(self, topic: str):
        """Decoder of a topic's CDR messages (attribute access to fields)."""
        if topic not in self._decoders:
            info = next((c for c in self.channels.values() if c.topic == topic), None)
            if info is None:
                raise RecordingError(f'{self.path}: no topic {topic!r} (has: '
                                     f'{", ".join(sorted(self.topics))})')
            try:
                self._decoders[topic] = generate_dynamic(info.type, info.schema_text)[info.type]
            except Exception as exc:  # noqa: BLE001 - a broken schema in a foreign file
                raise RecordingError(f'{self.path}: cannot parse the schema of {topic} '
                                     f'({info.type}): {_why(exc)}') from None
        return self._decoders[topic]

    def decoded(self, topics=None):
        """``(topic, log_time_ns, message)`` with decoded messages, in file order."""
        for topic, t, data in self.messages(topics):
            try:
                yield topic, t, self.decoder(topic)(data)
            except RecordingError:
                raise
            except Exception as exc:  # noqa: BLE001 - CDR that does not match its schema
                raise RecordingError(f'{self.path}: message on {topic} at {t} ns does not '
                                     f'decode as {self.topics[topic]}: {_why(exc)}') from None


def _why(exc) -> str:
    return f'{type(exc).__name__}: {exc}' if str(exc) else type(exc).__name__


def open_recording(path) -> Recording:
    """Open and validate a recording (ROS 2 profile, CDR messages, ros2msg schemas)."""
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f'{path}: no such file')
    with open(path, 'rb') as f:
        head = f.read(8)
        f.seek(max(0, path.stat().st_size - 8))
        tail = f.read(8)
    if head[:5] != _MAGIC:
        raise RecordingError(f'{path}: not an MCAP file')
    if tail[:5] != _MAGIC:
        raise RecordingError(f'{path}: incomplete MCAP file (no footer: its recorder was '
                             f'killed or is still writing); run `drill-twin mcap recover '
                             f'{path} FIXED.mcap`')
    try:
        with open(path, 'rb') as f:
            reader = SeekingReader(f, validate_crcs=True)
            header = reader.get_header()
            summary = reader.get_summary()
            metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()} \
                if summary is not None else {}
    except _READ_ERRORS as exc:
        raise RecordingError(f'{path}: unreadable MCAP ({_why(exc)}); if it was being written '
                             f'when its recorder died, run `drill-twin mcap recover {path} '
                             'FIXED.mcap`') from None
    if header.profile != PROFILE:
        raise RecordingError(f'{path}: not a ROS 2 recording (MCAP profile '
                             f'{header.profile!r}, expected {PROFILE!r})')
    if summary is None:
        raise RecordingError(f'{path}: the file has no summary (its recorder was killed or '
                             f'is still writing); run `drill-twin mcap recover {path} '
                             'FIXED.mcap`')
    channels = {}
    for cid, ch in summary.channels.items():
        schema = summary.schemas.get(ch.schema_id)
        if ch.message_encoding != 'cdr' or schema is None or schema.encoding != 'ros2msg':
            raise RecordingError(
                f'{path}: channel {ch.topic} is not a ROS 2 CDR channel (message encoding '
                f'{ch.message_encoding!r}, schema encoding '
                f'{getattr(schema, "encoding", None)!r})')
        channels[cid] = ChannelInfo(ch.topic, schema.name, schema.data.decode(),
                                    ch.metadata.get('offered_qos_profiles', ''))
    counts = {}
    if summary.statistics is not None:
        for cid, n in summary.statistics.channel_message_counts.items():
            counts[channels[cid].topic] = n
    run = metadata.get(RUN_METADATA)
    if run is not None:
        for key in ('scenario', 'twin', 'overrides'):
            if key in run:
                try:
                    run[key] = json.loads(run[key])
                except json.JSONDecodeError:
                    raise RecordingError(f'{path}: run metadata {key!r} is not JSON') from None
    return Recording(path, header.library, channels, metadata, counts)


def recover(broken, fixed) -> dict:
    """Rewrite the readable part of a (killed) recording into a complete, indexed file.

    Reads records in order with CRC checks and keeps every schema, channel,
    metadata record and message up to the first damaged or incomplete
    record (a chunk is all or nothing: the open chunk of a killed recorder is
    dropped).  Returns counts: ``messages``, ``channels``, ``complete`` (the
    input already had its summary) and ``stopped_at`` (why reading stopped).
    """
    broken, fixed = Path(broken), Path(fixed)
    if broken.resolve() == fixed.resolve():
        raise RecordingError('recover writes a new file: give a different output path')
    if not broken.is_file():
        raise RecordingError(f'{broken}: no such file')
    with open(broken, 'rb') as f:
        if f.read(8)[:5] != _MAGIC:
            raise RecordingError(f'{broken}: not an MCAP file')
    schemas, channels, items, header, stopped = {}, {}, [], None, 'end of file'
    complete = False
    try:
        with open(broken, 'rb') as f:
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Header):
                    header = record
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, (Message, Metadata)):
                    items.append(record)
            complete = True
    except _READ_ERRORS as exc:
        stopped = _why(exc)
    if header is None:
        raise RecordingError(f'{broken}: no readable MCAP header')
    if header.profile != PROFILE:
        raise RecordingError(f'{broken}: not a ROS 2 recording (profile {header.profile!r})')
    counts = {'messages': 0, 'channels': len(channels), 'complete': complete,
              'stopped_at': stopped}
    with open(fixed, 'wb') as out:
        writer = Writer(out, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile, library=header.library)
        sid = {k: writer.register_schema(s.name, s.encoding, s.data) for k, s in schemas.items()}
        cid = {k: writer.register_channel(c.topic, c.message_encoding, sid.get(c.schema_id, 0),
                                          dict(c.metadata)) for k, c in channels.items()}
        for item in items:
            if isinstance(item, Metadata):
                writer.add_metadata(item.name, dict(item.metadata))
            elif item.channel_id in cid:
                writer.add_message(cid[item.channel_id], log_time=item.log_time,
                                   data=item.data, publish_time=item.publish_time,
                                   sequence=item.sequence)
                counts['messages'] += 1
        writer.finish()
    return counts
