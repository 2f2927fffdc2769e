"""Republish a recording on its topics, with its timing (``drill-twin replay``).

Messages go out as recorded (raw CDR, no re-encoding) on the recorded topic
names, with the QoS each channel's ``offered_qos_profiles`` says.  Timing:
message *k* is published at wall time ``(log_time_k - log_time_0) / rate``
after the start (steady clock); with ``as_fast_as_possible`` there is no
pacing and ``/clock`` carries the log time so that nodes with
``use_sim_time`` follow the recording's time.
"""
from __future__ import annotations

import time

import yaml
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from ..errors import ParameterError
from ..io.mcap_reader import Recording
from ..topics import QoS
from .messages import available as installed
from .messages import message_class, qos_profile

__all__ = ['Player', 'offered_qos']


def offered_qos(text: str) -> QoS:
    """First profile of an ``offered_qos_profiles`` YAML list (reliable/volatile/10 if none);
    accepts the names (rosbag2 >= Jazzy) and the integer enums (older rosbag2)."""
    try:
        first = (yaml.safe_load(text) or [{}])[0]
    except (yaml.YAMLError, IndexError, TypeError):
        first = {}
    rel = {1: 'reliable', 2: 'best_effort'}
    dur = {1: 'transient_local', 2: 'volatile'}
    r = first.get('reliability', 'reliable')
    d = first.get('durability', 'volatile')
    r = rel.get(r, r) if isinstance(r, int) else str(r)
    d = dur.get(d, d) if isinstance(d, int) else str(d)
    return QoS(r if r in ('reliable', 'best_effort') else 'reliable',
               d if d in ('volatile', 'transient_local') else 'volatile',
               int(first.get('depth', 10) or 10))


class Player(Node):
    """Publishes a :class:`~drill_twin.io.mcap_reader.Recording` (see module docstring)."""

    def __init__(self, recording: Recording, topics=None, rate: float = 1.0,
                 as_fast_as_possible: bool = False, clock=time.monotonic, sleep=time.sleep,
                 **kwargs):
        super().__init__('drill_twin_player', **kwargs)
        self._clock, self._sleep = clock, sleep  # steady clock and sleep (tests inject)
        if not (rate > 0):
            raise ParameterError(f'rate must be > 0, got {rate}')
        self.recording = recording
        self.rate = float(rate)
        self.fast = bool(as_fast_as_possible)
        available = recording.topics
        self.topics = list(topics) if topics else list(available)
        missing = [t for t in self.topics if t not in available]
        if missing:
            raise ParameterError(f'{recording.path} has no topic(s) {missing}; it has: '
                             f'{", ".join(sorted(available))}')
        absent = [t for t in self.topics if not installed(available[t])]
        if absent:   # e.g. /tf without tf2_msgs (the PyPI ROS wheels): not published
            self.get_logger().warning(f'not publishing {", ".join(absent)}: message package '
                                      'not installed')
            self.topics = [t for t in self.topics if t not in absent]
        qos = {c.topic: offered_qos(c.offered_qos_profiles) for c in recording.channels.values()}
        self.pubs = {t: self.create_publisher(message_class(available[t]), t,
                                              qos_profile(qos[t])) for t in self.topics}
        self.clock_pub = None
        if self.fast:
            self.clock_pub = self.create_publisher(Clock, '/clock', 10)
            self.pubs.pop('/clock', None)  # the player's /clock replaces a recorded one
        self.published = 0

    def play(self, stop=None) -> int:
        """Publish every selected message; ``stop()`` -> True ends early.  Returns the count."""
        start = self._clock()
        t0 = None
        for topic, t_ns, data in self.recording.messages(self.topics):
            if stop is not None and stop():
                break
            t0 = t_ns if t0 is None else t0
            if self.fast:
                clock = Clock()
                clock.clock.sec, clock.clock.nanosec = divmod(t_ns, 1_000_000_000)
                self.clock_pub.publish(clock)
            else:
                delay = start + (t_ns - t0) * 1e-9 / self.rate - self._clock()
                if delay > 0:
                    self._sleep(delay)  # pacing to the recorded timing
            pub = self.pubs.get(topic)
            if pub is not None:
                pub.publish(data)
                self.published += 1
        return self.published
