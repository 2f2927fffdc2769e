"""A crash-safe MCAP writer in the rosbag2 profile.

What makes the file a rosbag2 file (what ``ros2 bag``, Foxglove, PlotJuggler and
``rosbags`` look for): header profile ``ros2``; one schema per message type,
named ``pkg/msg/Type``, encoding ``ros2msg``, data = the full concatenated
definition (:func:`~drill_twin.io.msg_definitions.schema_text`); channels with
message encoding ``cdr`` and metadata ``offered_qos_profiles`` (a YAML list in
the rosbag2 Jazzy layout); chunk indexes, message indexes, statistics and a
summary, all written by ``mcap.writer.Writer`` on :meth:`McapRecorder.close`.

Crash safety: the ``mcap`` writer only closes a chunk when it reaches its size
(1 MiB by default), so a killed process loses everything since the last full
chunk.  Here a chunk is closed, written and flushed to the OS as soon as it
holds ``chunk_period_s`` of log time or has been open that long on the wall
clock (whichever comes first), and :meth:`McapRecorder.flush` lets an idle
recorder close it on a timer.  A SIGKILL therefore loses at most the open
chunk; :func:`drill_twin.io.mcap_reader.recover` rebuilds the summary.

Time base (documented in the README): log time = publish time = the
recorder's clock in nanoseconds: simulated time for the twin's own recorder
and ``drill-twin simulate --out`` (t = 0 at the start of the simulation), the
recorder node's ROS time for ``mcap_recorder`` (simulated when it runs with
``use_sim_time`` on the twin's ``/clock``, system time otherwise).
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

from mcap.writer import CompressionType, Writer
from mcap_ros2._dynamic import serialize_dynamic

from ..topics import QoS
from .msg_definitions import normalize_type, schema_text

__all__ = ['McapRecorder', 'qos_yaml', 'PROFILE']

PROFILE = 'ros2'


def qos_yaml(qos: QoS) -> str:
    """``offered_qos_profiles`` metadata of one publisher (rosbag2 metadata version 9;
    zero durations mean "default", as rosbag2 writes them)."""
    zero = '\n    sec: 0\n    nsec: 0'
    return (f'- history: keep_last\n  depth: {qos.depth}\n'
            f'  reliability: {qos.reliability}\n  durability: {qos.durability}\n'
            f'  deadline:{zero}\n  lifespan:{zero}\n  liveliness: automatic\n'
            f'  liveliness_lease_duration:{zero}\n  avoid_ros_namespace_conventions: false')


class McapRecorder:
    """Write ROS 2 messages to a rosbag2-profile MCAP file (see module docstring).

    Parameters
    ----------
    path : str or Path
        Output file (parent directories are created).
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
            raise ValueError(f'chunk_period_s must be > 0, got {chunk_period_s}')
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(self.path, 'wb')  # noqa: SIM115 - closed in close()
        self._writer = Writer(self._file, compression=CompressionType[compression.upper()])
        self._writer.start(profile=PROFILE, library=library)
        self._file.flush()
        self.chunk_period_s = float(chunk_period_s)
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._encoders: dict[str, object] = {}
        self._channel_type: dict[str, str] = {}
        self._chunk_wall = None  # wall time / log time of the open chunk's first message
        self._chunk_log = None
        self._lock = threading.Lock()
        self.messages_written = 0
        self.closed = False

    # --- channels ------------------------------------------------------------------
    def channel(self, topic: str, type_name: str, qos: QoS) -> int:
        """Channel id of ``topic`` (registered with its schema on first use)."""
        cid = self._channels.get(topic)
        if cid is not None:
            return cid
        pkg, name = normalize_type(type_name)
        full = f'{pkg}/msg/{name}'
        sid = self._schemas.get(full)
        if sid is None:
            text = schema_text(full)
            sid = self._writer.register_schema(full, 'ros2msg', text.encode())
            self._schemas[full] = sid
            self._encoders[full] = serialize_dynamic(full, text)[full]
        cid = self._writer.register_channel(topic, 'cdr', sid,
                                            {'offered_qos_profiles': qos_yaml(qos)})
        self._channels[topic] = cid
        self._channel_type[topic] = full
        return cid

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
            data = message if isinstance(message, (bytes, bytearray, memoryview)) else \
                self._encoders[self._channel_type[topic]](message)
            log_time_ns = int(log_time_ns)
            self._writer.add_message(cid, log_time=log_time_ns, data=bytes(data),
                                     publish_time=int(publish_time_ns if publish_time_ns
                                                      is not None else log_time_ns),
                                     sequence=self.messages_written)
            self.messages_written += 1
            now = time.monotonic()
            if self._chunk_wall is None:
                self._chunk_wall, self._chunk_log = now, log_time_ns
            elif (now - self._chunk_wall >= self.chunk_period_s or
                  abs(log_time_ns - self._chunk_log) >= self.chunk_period_s * 1e9):
                self._close_chunk()

    def flush(self):
        """Close the open chunk now (call on a timer so an idle recorder loses nothing)."""
        with self._lock:
            if not self.closed and self._chunk_wall is not None:
                self._close_chunk()

    def _close_chunk(self):
        # mcap.writer.Writer has no public "end chunk now"; its private method is the one
        # it calls itself when a chunk is full.
        self._writer._Writer__finalize_chunk()  # noqa: SLF001
        self._file.flush()
        self._chunk_wall = self._chunk_log = None

    def add_metadata(self, name: str, data: dict):
        """An MCAP metadata record (string keys and values)."""
        with self._lock:
            self._writer.add_metadata(name, {str(k): str(v) for k, v in data.items()})
            self._file.flush()

    def close(self):
        """Write the last chunk, the indexes and the summary; idempotent."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            self._writer.finish()
            self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
