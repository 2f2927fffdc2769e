"""A Foxglove WebSocket server of the twin's topics (``foxglove-sdk``; no rclpy).

Every topic given is advertised on start, with its ROS 2 schema: schema encoding
``ros2msg`` (the full definition text rosbag2 writes,
:func:`drill_twin.io.msg_definitions.schema_text`), message encoding ``cdr``
(:func:`drill_twin.io.cdr.encoder_for`), so that the Foxglove app plots and draws it
without configuration, as it does a recording.  Names are fully qualified
(``/bit/velocity``), as in a recording.

Cost to the loop that feeds it: :meth:`LiveView.publish` only checks that a client
subscribes to the topic and appends the message's fields to a bounded queue (a few
microseconds); a worker thread of the view encodes it to CDR and hands the bytes to the
SDK (``log``), yielding the interpreter after every message so that the loop's thread,
when its timer fires, waits for it no longer than one encoding.  The SDK's own threads
write to each client through a bounded queue (``message_backlog_size``): a slow client
loses its oldest messages, a vanished one is dropped; neither waits on the loop.  When the
worker falls behind (more than ``queue`` messages waiting), the oldest are dropped and
counted (:attr:`LiveView.dropped`).

Latched topics (transient-local QoS: ``/tf_static``, the well, the stability advisory) have
no equivalent in the protocol: the last message of each is sent again when a client
subscribes to it.
"""
from __future__ import annotations

import collections
import threading
import time

from ..io.cdr import encoder_for
from ..io.msg_definitions import schema_text
from ..topics import Topic
from .compat import ProtocolFront

__all__ = ['LiveView', 'DEFAULT_PORT', 'LOCALHOST']

#: the Foxglove app's default WebSocket address is ws://localhost:8765
DEFAULT_PORT = 8765
#: the server listens on the loopback interface only
LOCALHOST = '127.0.0.1'


def _qualified(name: str, namespace: str) -> str:
    return name if name.startswith('/') else namespace.rstrip('/') + '/' + name


class _Listener:
    """Re-sends a latched topic's last message when a client subscribes to it."""

    def __init__(self, view):
        self.view = view

    def on_subscribe(self, client, channel):
        self.view._subscribed(channel.topic)

    def on_unsubscribe(self, client, channel):
        return None


class LiveView:
    """The twin's topics on a Foxglove WebSocket server (module docstring).

    Parameters
    ----------
    topics : iterable of Topic
        What is advertised (entries of :data:`drill_twin.topics.TOPICS`).
    port : int
        TCP port on ``host``; 0 = any free port (:attr:`port` says which).
    namespace : str
        ROS namespace of the relative topic names.
    host : str
        Interface to listen on (default: loopback only).
    backlog : int
        Messages queued per client before its oldest are dropped.
    name : str
        Server name the client shows.
    queue : int
        Messages waiting for the worker before the oldest are dropped.
    """

    def __init__(self, topics, port: int = DEFAULT_PORT, namespace: str = '/',
                 host: str = LOCALHOST, backlog: int = 1024, name: str = 'drill_twin',
                 queue: int = 4096):
        import foxglove
        self._foxglove = foxglove
        self.context = foxglove.Context()
        self._channels = {}       # relative or absolute topic name -> (channel, encode)
        self._latched = {}        # qualified name -> (channel, last bytes, log time)
        self._lock = threading.Lock()
        #: messages handed to the server, those that failed to encode, those dropped
        self.sent = 0
        self.failed = 0
        self._queue = collections.deque()
        self._queue_limit = int(queue)
        self.dropped = 0
        self._wake = threading.Event()
        self._closing = False
        for topic in topics:
            self._advertise(topic, namespace)
        try:   # the SDK on a private loopback port, behind the front (live/compat.py)
            self.server = foxglove.start_server(
                name=name, host=LOCALHOST, port=0, context=self.context,
                server_listener=_Listener(self), message_backlog_size=int(backlog))
        except Exception as exc:  # noqa: BLE001 - the SDK raises its own error types
            self.server = None
            raise OSError(f'cannot serve the live view on {host}:{port}: {exc}') from None
        try:
            self.front = ProtocolFront(host, port, self.server.port)
        except OSError:
            self.server.stop()
            self.server = None
            raise
        self._worker = threading.Thread(target=self._work, name='drill_twin live view',
                                        daemon=True)
        self._worker.start()

    def _advertise(self, topic: Topic, namespace: str):
        full = _qualified(topic.name, namespace)
        text = schema_text(topic.type)
        schema = self._foxglove.Schema(name=topic.type, encoding='ros2msg',
                                       data=text.encode())
        channel = self._foxglove.Channel(full, schema=schema, message_encoding='cdr',
                                         context=self.context)
        latched = topic.qos.durability == 'transient_local'
        self._channels[topic.name] = (channel, encoder_for(topic.type, text), latched, full)

    @property
    def port(self) -> int:
        """The TCP port clients connect to (the front of :mod:`drill_twin.live.compat`)."""
        return self.front.port

    @property
    def url(self) -> str:
        return f'ws://localhost:{self.port}'

    @property
    def topics(self) -> list:
        """The advertised (qualified) topic names."""
        return [entry[3] for entry in self._channels.values()]

    def publish(self, name: str, fields: dict, log_time_ns: int):
        """Queue one message (``fields`` as in :mod:`drill_twin.topics`, not changed
        afterwards) of topic ``name`` for the server; nothing when no client subscribes to
        it (a latched topic keeps its last message for the next subscriber).  Never
        blocks."""
        entry = self._channels.get(name)
        if entry is None or not (entry[2] or entry[0].has_sinks()):
            return
        if len(self._queue) >= self._queue_limit:
            self._queue.popleft()
            self.dropped += 1
        self._queue.append((entry, fields, int(log_time_ns)))
        self._wake.set()

    def _work(self):
        """The worker: encode and log what :meth:`publish` queued."""
        queue = self._queue
        while not self._closing:
            self._wake.wait(0.5)
            self._wake.clear()
            while queue and not self._closing:
                (channel, encode, latched, full), fields, log_time = queue.popleft()
                try:
                    data = encode(fields)
                except Exception:  # noqa: BLE001 - a bad message costs the view only
                    self.failed += 1
                    continue
                if latched:
                    with self._lock:
                        self._latched[full] = (channel, data, log_time)
                if not latched or channel.has_sinks():
                    channel.log(data, log_time=log_time)
                    self.sent += 1
                time.sleep(0)      # let the loop's thread have the interpreter

    def flush(self, timeout: float = 5.0) -> bool:
        """Wait until the worker has handed every queued message to the server."""
        deadline = time.monotonic() + timeout
        while self._queue and time.monotonic() < deadline:
            time.sleep(0.001)
        return not self._queue

    def publish_all(self, messages, log_time_ns: int):
        """:meth:`publish` of ``[(topic or name, fields)]``
        (:func:`drill_twin.topics.measurement_messages`)."""
        for topic, fields in messages:
            self.publish(getattr(topic, 'name', topic), fields, log_time_ns)

    def setpoint(self, name: str, value: float, log_time_ns: int):
        """A set-point as the twin applied it (``std_msgs/Float64``)."""
        self.publish(name, {'data': float(value)}, log_time_ns)

    def _subscribed(self, full: str):
        with self._lock:
            latched = self._latched.get(full)
        if latched is not None:
            channel, data, log_time = latched
            channel.log(data, log_time=log_time)

    def close(self):
        """Stop the server (clients are disconnected) and close the channels."""
        self._closing = True
        self._wake.set()
        if getattr(self, '_worker', None) is not None:
            self._worker.join(5.0)
        front, self.front = getattr(self, 'front', None), None
        if front is not None:
            front.close()
        server, self.server = self.server, None
        if server is not None:
            server.stop()
        for channel, *_ in self._channels.values():
            channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
