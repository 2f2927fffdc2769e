"""A crash-safe, bounded-memory MCAP writer in the rosbag2 profile.

What makes the file a rosbag2 file (what ``ros2 bag``, Foxglove, PlotJuggler and
``rosbags`` look for): header profile ``ros2``; one schema per message type,
named ``pkg/msg/Type``, encoding ``ros2msg``, data = the full concatenated
definition (:func:`~drill_twin.io.msg_definitions.schema_text`); channels with
message encoding ``cdr`` and metadata ``offered_qos_profiles`` (a YAML list in
the rosbag2 Jazzy layout); chunk indexes, message indexes, statistics and a
summary.

The file is written with the record classes of the ``mcap`` package
(``mcap.records``, ``mcap.data_stream.RecordBuilder``: public API); the chunking
is this module's own, because it decides what a crash can lose and how much
memory a long recording takes:

Crash safety
    Schemas, channels and metadata are written (and flushed) outside chunks the
    moment they are registered.  A chunk is closed, written with its message
    indexes and flushed to the OS as soon as it holds ``chunk_period_s`` of log
    time or has been open that long on the wall clock (whichever comes first);
    :meth:`McapRecorder.flush` lets an idle recorder close it on a timer.  A
    SIGKILL therefore loses at most the open chunk;
    :func:`drill_twin.io.mcap_reader.recover` rebuilds the summary.
Bounded memory
    The summary needs one chunk index per chunk (about 1.4 kB each with the
    twin's channels: 20 MB an hour at 0.25 s chunks if kept in memory).  They are
    serialised to an anonymous temporary file as chunks close and copied into
    the summary at :meth:`McapRecorder.close`; what stays in memory is the open
    chunk and per-channel counters, whatever the length of the recording.

Time base (documented in the README): log time = publish time = the
recorder's clock in nanoseconds: simulated time for the twin's own recorder
and ``drill-twin simulate --out`` (t = 0 at the start of the simulation), the
recorder node's ROS time for ``mcap_recorder`` (simulated when it runs with
``use_sim_time`` on the twin's ``/clock``, system time otherwise).
"""
from __future__ import annotations

import errno
import struct
import tempfile
import threading
import time
import zlib
from pathlib import Path

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from ..errors import ParameterError
from ..topics import QoS
from .cdr import encoder_for
from .msg_definitions import normalize_type, schema_text, type_hash
from .rosbag2_metadata import (
    RECORD_NAME,
    bag_directory,
    bag_metadata,
    serialized_metadata,
    topic_entry,
    write_bag_metadata_file,
)

__all__ = ['McapRecorder', 'qos_yaml', 'PROFILE', 'MAGIC']

PROFILE = 'ros2'
#: the 8 bytes that open and close every MCAP file (spec: 0x89 "MCAP0" CR LF)
MAGIC = b'\x89MCAP0\r\n'


def qos_yaml(qos: QoS) -> str:
    """``offered_qos_profiles`` metadata of one publisher (rosbag2 metadata version 9;
    zero durations mean "default", as rosbag2 writes them)."""
    zero = '\n    sec: 0\n    nsec: 0'
    return (f'- history: keep_last\n  depth: {qos.depth}\n'
            f'  reliability: {qos.reliability}\n  durability: {qos.durability}\n'
            f'  deadline:{zero}\n  lifespan:{zero}\n  liveliness: automatic\n'
            f'  liveliness_lease_duration:{zero}\n  avoid_ros_namespace_conventions: false')


def _compressor(name: str):
    if name == 'zstd':
        import zstandard
        return 'zstd', zstandard.ZstdCompressor().compress
    if name == 'lz4':
        import lz4.frame
        return 'lz4', lz4.frame.compress
    if name == 'none':
        return '', bytes
    raise ParameterError(f"compression must be 'zstd', 'lz4' or 'none', got {name!r}")


class _OpenChunk:
    """The records of the chunk being filled and its per-channel message index."""

    def __init__(self):
        self.records = RecordBuilder()
        self.index: dict[int, list] = {}
        self.start = self.end = None
        self.opened_wall = None

    def add(self, message: Message):
        self.index.setdefault(message.channel_id, []).append(
            (message.log_time, self.records.count))
        message.write(self.records)
        t = message.log_time
        self.start = t if self.start is None else min(self.start, t)
        self.end = t if self.end is None else max(self.end, t)
        if self.opened_wall is None:
            self.opened_wall = time.monotonic()

    @property
    def empty(self) -> bool:
        return self.opened_wall is None


class McapRecorder:
    """Write ROS 2 messages to a rosbag2-profile MCAP file (see module docstring).

    Parameters
    ----------
    path : str or Path
        Output file (parent directories are created); a path without a suffix is a
        rosbag2 bag directory: ``DIR/DIR_0.mcap``, and ``DIR/metadata.yaml`` written at
        close (what ``ros2 bag record -o DIR -s mcap`` leaves).
    chunk_period_s : float
        Longest span of log time, or of wall time, that one chunk holds [s]:
        the most a SIGKILL can lose.
    compression : {'zstd', 'lz4', 'none'}
        Chunk compression.
    library : str
        Written in the MCAP header.
    """

    def __init__(self, path, chunk_period_s: float = 0.25, compression: str = 'zstd',
                 library: str = 'drill_twin'):
        if not chunk_period_s > 0:
            raise ParameterError(f'chunk_period_s must be > 0, got {chunk_period_s}')
        self.bag_directory = bag_directory(path)
        self.path = Path(path) if self.bag_directory is None else \
            self.bag_directory / f'{self.bag_directory.name}_0.mcap'
        self.chunk_period_s = float(chunk_period_s)
        self._compression, self._compress = _compressor(compression)
        try:
            if self.bag_directory is not None and self.bag_directory.exists():
                raise FileExistsError(errno.EEXIST, 'the bag directory exists (rosbag2 '
                                      'does not record into one either)')
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, 'wb')  # noqa: SIM115 - closed in close()
        except OSError as exc:
            raise OSError(f'cannot write the recording {self.path}: '
                          f'{exc.strerror or exc}') from None
        self._chunk_indexes = tempfile.TemporaryFile()  # noqa: SIM115 - closed in close()
        self._lock = threading.Lock()
        self._schemas: dict[str, Schema] = {}
        self._channels: dict[str, Channel] = {}
        self._encoders: dict[str, object] = {}   # by topic
        self._metadata_indexes: list[MetadataIndex] = []
        self._chunk = _OpenChunk()
        self._counts: dict[int, int] = {}
        self._start_time = self._end_time = None
        self._chunk_count = 0
        self.messages_written = 0
        self.closed = False
        self._emit(Header(profile=PROFILE, library=library), magic=True)

    # --- low level -----------------------------------------------------------------
    def _emit(self, *records, magic: bool = False):
        """Write records at the end of the data section and hand them to the OS."""
        builder = RecordBuilder()
        offset = self._file.tell() + (len(MAGIC) if magic else 0)
        for record in records:
            record.write(builder)
        if magic:
            self._file.write(MAGIC)
        self._file.write(builder.end())
        self._file.flush()
        return offset

    # --- channels ------------------------------------------------------------------
    def channel(self, topic: str, type_name: str, qos: QoS) -> int:
        """Channel id of ``topic`` (registered with its schema on first use)."""
        channel = self._channels.get(topic)
        if channel is not None:
            return channel.id
        pkg, name = normalize_type(type_name)
        full = f'{pkg}/msg/{name}'
        schema = self._schemas.get(full)
        if schema is None:
            text = schema_text(full)
            schema = Schema(id=len(self._schemas) + 1, name=full, encoding='ros2msg',
                            data=text.encode())
            self._schemas[full] = schema
            self._emit(schema)
        channel = Channel(id=len(self._channels) + 1, topic=topic, message_encoding='cdr',
                          schema_id=schema.id,
                          metadata={'offered_qos_profiles': qos_yaml(qos),
                                    'topic_type_hash': type_hash(full)})
        self._channels[topic] = channel
        self._encoders[topic] = encoder_for(full, schema.data.decode())
        self._emit(channel)
        return channel.id

    # --- messages ------------------------------------------------------------------
    def write(self, topic: str, type_name: str, qos: QoS, message, log_time_ns: int,
              publish_time_ns: int | None = None):
        """Record one message.

        ``message``: CDR ``bytes`` (as received with a raw subscription) or the
        message fields (nested dict, or any object with the field attributes),
        serialised here from the schema.  Thread-safe.
        """
        with self._lock:
            if self.closed:
                raise ValueError(f'{self.path} is closed')
            cid = self.channel(topic, type_name, qos)
            if not isinstance(message, (bytes, bytearray, memoryview)):
                message = self._encoders[topic](message)
            log_time_ns = int(log_time_ns)
            self._chunk.add(Message(
                channel_id=cid, sequence=self.messages_written, log_time=log_time_ns,
                publish_time=int(publish_time_ns if publish_time_ns is not None
                                 else log_time_ns), data=bytes(message)))
            self._counts[cid] = self._counts.get(cid, 0) + 1
            self._start_time = log_time_ns if self._start_time is None else \
                min(self._start_time, log_time_ns)
            self._end_time = log_time_ns if self._end_time is None else \
                max(self._end_time, log_time_ns)
            self.messages_written += 1
            chunk = self._chunk
            if (time.monotonic() - chunk.opened_wall >= self.chunk_period_s or
                    chunk.end - chunk.start >= self.chunk_period_s * 1e9):
                self._close_chunk()

    def flush(self):
        """Close the open chunk now (call on a timer so an idle recorder loses nothing)."""
        with self._lock:
            if not self.closed:
                self._close_chunk()

    def _close_chunk(self):
        chunk = self._chunk
        if chunk.empty:
            return
        data = chunk.records.end()
        compressed = self._compress(data)
        record = Chunk(message_start_time=chunk.start, message_end_time=chunk.end,
                       uncompressed_size=len(data), uncompressed_crc=zlib.crc32(data),
                       compression=self._compression, data=compressed)
        builder = RecordBuilder()
        record.write(builder)
        chunk_length = builder.count
        offsets = {}
        for cid, entries in chunk.index.items():
            offsets[cid] = builder.count  # from the chunk's start
            MessageIndex(channel_id=cid, records=entries).write(builder)
        chunk_offset = self._file.tell()
        blob = builder.end()
        self._file.write(blob)
        self._file.flush()
        index = ChunkIndex(
            message_start_time=chunk.start, message_end_time=chunk.end,
            chunk_start_offset=chunk_offset, chunk_length=chunk_length,
            message_index_offsets={cid: chunk_offset + off for cid, off in offsets.items()},
            message_index_length=len(blob) - chunk_length, compression=self._compression,
            compressed_size=len(compressed), uncompressed_size=len(data))
        spill = RecordBuilder()
        index.write(spill)
        self._chunk_indexes.write(spill.end())
        self._chunk_count += 1
        self._chunk = _OpenChunk()

    def add_metadata(self, name: str, data: dict):
        """An MCAP metadata record (string keys and values)."""
        with self._lock:
            self._add_metadata(name, data)

    def _add_metadata(self, name: str, data: dict):
        record = Metadata(name=name, metadata={str(k): str(v) for k, v in data.items()})
        builder = RecordBuilder()
        record.write(builder)
        length = builder.count
        offset = self._emit(record)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=length, name=name))

    def bag_metadata(self) -> dict:
        """rosbag2's metadata of what was written so far (:mod:`.rosbag2_metadata`)."""
        schemas = {s.id: s.name for s in self._schemas.values()}
        topics = [topic_entry(c, schemas[c.schema_id], self._counts.get(c.id, 0))
                  for c in self._channels.values()]
        return bag_metadata(self.path.name, topics, self._start_time or 0,
                            self._end_time or 0)

    # --- the end -------------------------------------------------------------------
    def abandon(self):
        """Stop after a write failed (a full disk, a revoked permission): close the file
        without writing more; what the finished chunks hold stays in it, and
        :func:`drill_twin.io.mcap_reader.recover` reads it back.  Idempotent."""
        with self._lock:
            self.closed = True
            for handle in (self._file, self._chunk_indexes):
                try:
                    handle.close()
                except OSError:
                    pass

    def close(self):
        """Write the last chunk, the indexes and the summary; idempotent."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            self._close_chunk()
            self._add_metadata(RECORD_NAME, {'serialized_metadata': serialized_metadata(
                self.bag_metadata())})
            self._emit(DataEnd(data_section_crc=0))
            self._write_summary()
            self._file.close()
            self._chunk_indexes.close()
            if self.bag_directory is not None:
                write_bag_metadata_file(self.bag_directory, self.bag_metadata())

    def _write_summary(self):
        start = self._file.tell()
        crc = 0
        groups = []
        stats = Statistics(
            message_count=self.messages_written, schema_count=len(self._schemas),
            channel_count=len(self._channels), attachment_count=0,
            metadata_count=len(self._metadata_indexes), chunk_count=self._chunk_count,
            message_start_time=self._start_time or 0, message_end_time=self._end_time or 0,
            channel_message_counts=dict(self._counts))
        for opcode, records in ((Opcode.SCHEMA, list(self._schemas.values())),
                                (Opcode.CHANNEL, list(self._channels.values())),
                                (Opcode.STATISTICS, [stats]),
                                (Opcode.CHUNK_INDEX, None),
                                (Opcode.METADATA_INDEX, self._metadata_indexes)):
            group_start = self._file.tell()
            if records is None:  # the chunk indexes, streamed from the spill file
                self._chunk_indexes.seek(0)
                while block := self._chunk_indexes.read(1 << 20):
                    crc = zlib.crc32(block, crc)
                    self._file.write(block)
            else:
                builder = RecordBuilder()
                for record in records:
                    record.write(builder)
                block = builder.end()
                crc = zlib.crc32(block, crc)
                self._file.write(block)
            groups.append(SummaryOffset(group_opcode=opcode, group_start=group_start,
                                        group_length=self._file.tell() - group_start))
        offsets_start = self._file.tell()
        builder = RecordBuilder()
        for group in groups:
            group.write(builder)
        block = builder.end()
        crc = zlib.crc32(block, crc)
        self._file.write(block)
        crc = zlib.crc32(struct.pack('<BQQQ', Opcode.FOOTER, 20, start, offsets_start), crc)
        builder = RecordBuilder()
        Footer(summary_start=start, summary_offset_start=offsets_start,
               summary_crc=crc).write(builder)
        self._file.write(builder.end())
        self._file.write(MAGIC)
        self._file.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
