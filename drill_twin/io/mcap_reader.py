"""Read drill_twin (rosbag2-profile) MCAP recordings, and recover killed ones.

Opening a recording validates it whole: header profile, summary, every channel a
ROS 2 CDR channel with a ``ros2msg`` schema, and every chunk against its indexes
(:func:`check_indexes`: the chunk's CRC, and the message indexes list exactly the
messages the chunk holds, at the log times and offsets they have), so that what
``info`` and ``export`` report is what an indexed reader (Foxglove, rosbag2)
sees.

Every failure of a corrupt, truncated or foreign file is raised as
:class:`RecordingError` with a sentence that says what is wrong and what to
do (e.g. "run ``drill-twin mcap recover``"), never a library traceback.

Reading is bounded whatever the bytes say: no read asks for more than the file
holds (a damaged length of 2^63 is a short read, not an allocation), a chunk
decompresses to at most :data:`MAX_CHUNK_BYTES` (a zstd frame may claim any size),
and a bag directory's ``metadata.yaml`` is read within the bounds of a
configuration file.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import struct
import zlib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Header, Message, MessageIndex, Metadata, Schema
from mcap.stream_reader import (
    CRCValidationError,
    StreamReader,
    breakup_chunk,
    get_chunk_data_stream,
)
from mcap.writer import CompressionType, Writer

from .cdr import decoder_for
from .mcap_writer import PROFILE
from .rosbag2_metadata import (
    METADATA_FILE,
    RECORD_NAME,
    bag_file,
    bag_metadata,
    serialized_metadata,
    topic_entry,
)

__all__ = ['RecordingError', 'Recording', 'open_recording', 'recover', 'check_indexes',
           'check_decodable', 'RUN_METADATA']

_MAGIC = b'\x89MCAP'
#: magic + header record + footer record + magic: no complete MCAP file is shorter
_SMALLEST = 8 + 9 + 8 + 9 + 20 + 8
#: name of the MCAP metadata record with the run description
RUN_METADATA = 'drill_twin'

_READ_ERRORS = (McapError, CRCValidationError, struct.error, EOFError, ValueError,
                KeyError, IndexError, UnicodeDecodeError, zlib.error, OSError, RuntimeError)
try:  # the chunk decompressors raise their own errors
    import zstandard
    _READ_ERRORS += (zstandard.ZstdError,)
except ImportError:  # pragma: no cover
    zstandard = None


class RecordingError(Exception):
    """A recording that cannot be read as a drill_twin/rosbag2 MCAP file (message says why)."""


#: largest uncompressed chunk read [bytes].  This package's writer closes a chunk after
#: 0.25 s of messages (~0.5 MB at 1 kHz), the mcap C++ writer (rosbag2) at 768 KiB; a
#: damaged size field or a zstd frame that claims gigabytes (a few kB of compressed zeros
#: can) is refused instead of allocated.
MAX_CHUNK_BYTES = 64 << 20


class _Bounded:
    """A binary file whose ``read(n)`` asks for at most what is left of it: the mcap
    library reads a length field's worth of bytes, and a damaged one (2^63) would be an
    allocation of that size (MemoryError, OverflowError), not a short read."""

    def __init__(self, f, size: int | None = None):
        self._f = f
        self._size = os.fstat(f.fileno()).st_size if size is None else size

    def read(self, n=-1):
        if n is None or n < 0:
            return self._f.read()
        return self._f.read(max(0, min(n, self._size - self._f.tell())))

    def seek(self, offset, whence=io.SEEK_SET):
        return self._f.seek(offset, whence)

    def tell(self):
        return self._f.tell()

    def seekable(self):
        return True


def _check_chunk_size(chunk, where: str):
    """Refuse a chunk that would decompress to more than :data:`MAX_CHUNK_BYTES`."""
    size = chunk.uncompressed_size
    if chunk.compression == 'zstd' and zstandard is not None and size <= MAX_CHUNK_BYTES:
        try:   # a zstd frame that states its size is decompressed to it, whatever the chunk says
            size = max(size, zstandard.frame_content_size(chunk.data))
        except zstandard.ZstdError as exc:
            raise RecordingError(f'{where}: damaged zstd data ({exc})') from None
    if size > MAX_CHUNK_BYTES:
        raise RecordingError(f'{where}: decompresses to {size} bytes, more than the '
                             f'{MAX_CHUNK_BYTES} a chunk may hold (damaged)')


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
                reader = SeekingReader(_Bounded(f), validate_crcs=True)
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
            try:  # the message parser prints a line of its own before it raises: kept quiet
                with contextlib.redirect_stderr(io.StringIO()):
                    self._decoders[topic] = decoder_for(info.type, info.schema_text)
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


def _record_at(f, offset: int, opcode: int, what: str) -> bytes:
    """The body of the record of type ``opcode`` that starts at ``offset``."""
    f.seek(offset)
    head = f.read(9)
    if len(head) < 9:
        raise RecordingError(f'{what} at byte {offset} is past the end of the file')
    op, length = struct.unpack('<BQ', head)
    if op != opcode:
        raise RecordingError(f'{what} at byte {offset} is not there (opcode {op:#x})')
    if length > os.fstat(f.fileno()).st_size - offset - 9:   # not read: it may be 2^64
        raise RecordingError(f'{what} at byte {offset} claims {length} bytes, past the end '
                             'of the file')
    body = f.read(length)
    if len(body) != length:
        raise RecordingError(f'{what} at byte {offset} is truncated')
    return body


def _check_summary_crc(path):
    """The footer's CRC of the summary section (schemas, channels, statistics, indexes)."""
    with open(path, 'rb') as f:
        footer_at = f.seek(0, 2) - 8 - 29
        f.seek(footer_at)
        op, length, start, offsets, crc = struct.unpack('<BQQQI', f.read(29))
        if op != Opcode.FOOTER or length != 20:
            raise RecordingError('no footer record before the closing magic')
        if start == 0 or crc == 0:
            return  # no summary, or a writer that does not compute the CRC
        if not 0 < start <= footer_at:
            raise RecordingError('the footer points outside the file')
        f.seek(start)
        summary = f.read(footer_at - start)
    value = zlib.crc32(struct.pack('<BQQQ', Opcode.FOOTER, 20, start, offsets),
                       zlib.crc32(summary))
    if value != crc:
        raise RecordingError('the summary section does not match its CRC (damaged)')


def _chunk_messages(data: bytes) -> dict:
    """``{channel: [(log_time, offset), ...]}`` of the Message records in chunk data."""
    found: dict[int, list] = {}
    pos = 0
    while pos < len(data):
        op, length = struct.unpack_from('<BQ', data, pos)
        if op == Opcode.MESSAGE:
            cid, _, log_time = struct.unpack_from('<HIQ', data, pos + 9)
            found.setdefault(cid, []).append((log_time, pos))
        pos += 9 + length
    if pos != len(data):
        raise RecordingError('a chunk\'s records overrun its data')
    return found


def check_indexes(path, summary) -> Counter:
    """Check every chunk against the summary's chunk index and its message indexes.

    Raises :class:`RecordingError` at the first disagreement (what an indexed reader
    such as Foxglove's refuses); returns the message count per channel id found in
    the chunks, which must equal the statistics.
    """
    counts: Counter = Counter()
    with open(path, 'rb') as f:
        for n, ci in enumerate(summary.chunk_indexes):
            where = f'chunk {n} (byte {ci.chunk_start_offset})'
            body = _record_at(f, ci.chunk_start_offset, Opcode.CHUNK, where)
            if 9 + len(body) != ci.chunk_length:
                raise RecordingError(f'{where}: length disagrees with its chunk index')
            chunk = Chunk.read(ReadDataStream(_Bounded(io.BytesIO(body), len(body))))
            _check_chunk_size(chunk, where)
            stream, size = get_chunk_data_stream(chunk, validate_crc=True)
            messages = _chunk_messages(stream.read(size))
            times = [t for entries in messages.values() for t, _ in entries]
            if times and (min(times) != ci.message_start_time or
                          max(times) != ci.message_end_time):
                raise RecordingError(f'{where}: message times disagree with its chunk index')
            if set(ci.message_index_offsets) != set(messages):
                raise RecordingError(f'{where}: its message indexes name channels '
                                     f'{sorted(ci.message_index_offsets)}, it holds '
                                     f'{sorted(messages)}')
            for cid, offset in ci.message_index_offsets.items():
                body = _record_at(f, offset, Opcode.MESSAGE_INDEX, f'{where} message index')
                index = MessageIndex.read(ReadDataStream(_Bounded(io.BytesIO(body),
                                                                  len(body))))
                if index.channel_id != cid or sorted(index.records) != sorted(messages[cid]):
                    raise RecordingError(f'{where}: the message index of channel {cid} '
                                         'disagrees with the messages in the chunk')
                counts[cid] += len(messages[cid])
    stats = summary.statistics
    if stats is not None and dict(counts) != {k: v for k, v in
                                              stats.channel_message_counts.items() if v}:
        raise RecordingError('the message counts of the statistics disagree with the chunks')
    return counts


def _check_channel(path, channel, schema):
    if channel.message_encoding != 'cdr' or schema is None or schema.encoding != 'ros2msg':
        raise RecordingError(
            f'{path}: channel {channel.topic} is not a ROS 2 CDR channel (message encoding '
            f'{channel.message_encoding!r}, schema encoding '
            f'{getattr(schema, "encoding", None)!r})')


def open_recording(path) -> Recording:
    """Open and validate a recording (ROS 2 profile, CDR messages, ros2msg schemas): an
    ``.mcap`` file or a rosbag2 bag directory."""
    path = Path(path)
    if path.is_dir():
        path = _bag_file(path)
    if not path.is_file():
        raise RecordingError(f'{path}: no such file')
    with open(path, 'rb') as f:
        head = f.read(8)
        f.seek(max(0, path.stat().st_size - 8))
        tail = f.read(8)
    if head[:5] != _MAGIC:
        raise RecordingError(f'{path}: not an MCAP file')
    if tail[:5] != _MAGIC or path.stat().st_size < _SMALLEST:
        raise RecordingError(f'{path}: incomplete MCAP file (no footer: its recorder was '
                             f'killed or is still writing); run `drill-twin mcap recover '
                             f'{path} FIXED.mcap`')
    try:
        with open(path, 'rb') as f:
            reader = SeekingReader(_Bounded(f), validate_crcs=True)
            header = reader.get_header()
            summary = reader.get_summary()
            metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()} \
                if summary is not None else {}
        if summary is not None:
            _check_summary_crc(path)
            check_indexes(path, summary)
    except RecordingError as exc:
        raise RecordingError(f'{path}: corrupt MCAP index ({exc}); run `drill-twin mcap '
                             f'recover {path} FIXED.mcap` to rebuild the indexes') from None
    except _READ_ERRORS as exc:
        if 'CRCValidationError' in type(exc).__name__:   # damaged bytes, not a cut-off file
            raise RecordingError(f'{path}: corrupt MCAP data ({_why(exc)}); try `drill-twin '
                                 f'mcap recover {path} FIXED.mcap`') from None
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
        _check_channel(path, ch, schema)
        try:
            text = schema.data.decode()
        except UnicodeDecodeError:
            raise RecordingError(f'{path}: the schema of {ch.topic} ({schema.name}) is not '
                                 'text (damaged)') from None
        channels[cid] = ChannelInfo(ch.topic, schema.name, text,
                                    ch.metadata.get('offered_qos_profiles', ''))
    counts = {}
    if summary.statistics is not None:
        for cid, n in summary.statistics.channel_message_counts.items():
            if cid not in channels:
                raise RecordingError(f'{path}: the statistics count messages of channel '
                                     f'{cid}, which the summary does not define (damaged)')
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


#: what reading a damaged or foreign metadata.yaml raises (it is a mapping of lists)
_BAG_ERRORS = (yaml.YAMLError, OSError, UnicodeDecodeError, AttributeError, TypeError,
               ValueError, IndexError, KeyError)


def _bag_file(directory: Path) -> Path:
    """The MCAP file of a bag directory; its ``metadata.yaml`` is read within the bounds
    of a configuration file (size, nesting, aliases), and a damaged one is a
    :class:`RecordingError`."""
    from ..config.yaml_bounds import MAX_YAML_BYTES, check_yaml_bounds
    meta = directory / METADATA_FILE
    try:
        if meta.is_file():
            if meta.stat().st_size > MAX_YAML_BYTES:
                raise RecordingError(f'{meta}: larger than {MAX_YAML_BYTES} bytes: not a '
                                     'rosbag2 metadata file')
            check_yaml_bounds(meta.read_text())
        return bag_file(directory)
    except _BAG_ERRORS as exc:
        raise RecordingError(f'{meta}: not a rosbag2 metadata file ({_why(exc)})') from None


def check_decodable(recording: Recording, topics=None) -> dict:
    """Decode every message of ``topics`` (default all); raise :class:`RecordingError`
    naming each topic whose messages do not decode as its schema, with their count.
    Returns the message count per topic."""
    counts: Counter = Counter()
    bad: Counter = Counter()
    for topic, _, data in recording.messages(topics):
        counts[topic] += 1
        try:
            recording.decoder(topic)(data)
        except RecordingError:
            raise
        except Exception:  # noqa: BLE001 - CDR that does not match its schema
            bad[topic] += 1
    if bad:
        detail = '; '.join(f'{t}: {n} of {counts[t]} messages do not decode as '
                           f'{recording.topics[t]}' for t, n in sorted(bad.items()))
        raise RecordingError(f'{recording.path}: {detail}; not replayed')
    return dict(counts)


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
            for record in _records_in_order(f):
                if isinstance(record, Header):
                    header = record
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, (Message, Metadata)):
                    items.append(record)
            complete = True
    except (*_READ_ERRORS, RecordingError) as exc:
        stopped = _why(exc)
    if header is None:
        raise RecordingError(f'{broken}: no readable MCAP header')
    if header.profile != PROFILE:
        raise RecordingError(f'{broken}: not a ROS 2 recording (profile {header.profile!r})')
    for channel in channels.values():
        _check_channel(broken, channel, schemas.get(channel.schema_id))
    if complete:  # every record read: is the summary there, and do the indexes agree?
        try:
            with open(broken, 'rb') as f:
                summary = SeekingReader(_Bounded(f), validate_crcs=True).get_summary()
            if summary is None:
                complete, stopped = False, 'no summary'
            else:
                check_indexes(broken, summary)
        except RecordingError as exc:
            complete, stopped = False, f'indexes: {exc}'
        except _READ_ERRORS as exc:
            complete, stopped = False, f'summary: {_why(exc)}'
    counts = {'messages': 0, 'channels': len(channels), 'complete': complete,
              'stopped_at': stopped}
    with open(fixed, 'wb') as out:
        writer = Writer(out, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile, library=header.library)
        sid = {k: writer.register_schema(s.name, s.encoding, s.data) for k, s in schemas.items()}
        cid = {k: writer.register_channel(c.topic, c.message_encoding, sid.get(c.schema_id, 0),
                                          dict(c.metadata)) for k, c in channels.items()}
        for item in items:
            if isinstance(item, Metadata) and item.name == RECORD_NAME:
                continue   # rewritten below for what was recovered
            if isinstance(item, Metadata):
                writer.add_metadata(item.name, dict(item.metadata))
            elif item.channel_id in cid:
                writer.add_message(cid[item.channel_id], log_time=item.log_time,
                                   data=item.data, publish_time=item.publish_time,
                                   sequence=item.sequence)
                counts['messages'] += 1
        writer.add_metadata(RECORD_NAME, {'serialized_metadata': serialized_metadata(
            _recovered_metadata(fixed.name, schemas, channels, items))})
        writer.finish()
    return counts


def _records_in_order(f):
    """The records of an MCAP file in order, a chunk's in its place; a chunk that would
    decompress to more than :data:`MAX_CHUNK_BYTES` stops the reading as a damaged record
    does (:class:`RecordingError`)."""
    for record in StreamReader(_Bounded(f), validate_crcs=True, emit_chunks=True).records:
        if isinstance(record, Chunk):
            _check_chunk_size(record, 'a chunk')
            yield from breakup_chunk(record, validate_crc=True)
        else:
            yield record


def _recovered_metadata(file_name, schemas, channels, items) -> dict:
    """rosbag2's metadata record for the messages a recovery kept."""
    times = [m.log_time for m in items if isinstance(m, Message) and m.channel_id in channels]
    counts = {}
    for m in items:
        if isinstance(m, Message):
            counts[m.channel_id] = counts.get(m.channel_id, 0) + 1
    topics = [topic_entry(c, schemas[c.schema_id].name, counts.get(k, 0))
              for k, c in channels.items() if c.schema_id in schemas]
    return bag_metadata(file_name, topics, min(times, default=0), max(times, default=0))
